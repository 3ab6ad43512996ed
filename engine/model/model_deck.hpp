#pragma once
// The model deck: nodes, elements, sections, contacts, steps, ... (docs/input.md), its checked
// tables resolved into a Model. engine/input/read_deck.hpp reads a deck file and hands a deck
// without a [fabric] table here.

#include "engine/model/deck_schema.hpp"
#include "engine/model/model.hpp"

#include <toml++/toml.h>

namespace yarnsim {

/// The model of a model deck (`table`, parsed). Every problem is reported to `diagnostics`
/// ("file:line:col: path: message", unknown keys with suggestions) and the model returned is
/// then incomplete: the caller throws InputError when diagnostics is not empty.
Model read_model_deck(const toml::table& table, deck::Diagnostics& diagnostics);

} // namespace yarnsim
