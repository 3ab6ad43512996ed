#pragma once
// The fabric deck: a TOML deck that describes a woven fabric and its biaxial test ([fabric],
// [biaxial], optional [contact]) instead of nodes and elements (docs/input.md, "Fabric decks").
// read_deck() (engine/input/read_deck.hpp) hands a deck with a top-level "fabric" key to
// read_fabric_deck().

#include "engine/model/deck_schema.hpp"
#include "engine/model/model.hpp"

#include <filesystem>
#include <optional>
#include <toml++/toml.h>

namespace yarnsim::textile {

/// The model of a fabric deck: build_weave() of [fabric] (or read_texgen() of its `texgen` file,
/// a path relative to `folder`, the deck's folder) with the [contact] law, then
/// add_biaxial_test() of [biaxial]. Returns std::nullopt when `table` has no "fabric" key (an
/// ordinary deck). Every problem is reported to `diagnostics` ("file:line:col: path: message",
/// unknown keys with suggestions; a TexGen file's own problems after the `texgen` key's) and the
/// model returned is then incomplete: the caller throws InputError when diagnostics is not empty.
std::optional<Model> read_fabric_deck(const toml::table& table, deck::Diagnostics& diagnostics,
                                      const std::filesystem::path& folder);

} // namespace yarnsim::textile
