#pragma once
// The front door of the input: reads any deck file and hands it to the reader of its kind, a
// model deck (engine/model/model_deck.hpp) or a fabric deck, woven or from a TexGen file
// (engine/textile/fabric_deck.hpp). It sits above both, so that the model layer does not
// reach up to the textile layer.

#include "engine/model/deck.hpp"
#include "engine/model/model.hpp"

#include <filesystem>
#include <string_view>
#include <toml++/toml.h>

namespace yarnsim {

/// Reads and validates a deck; throws InputError listing ALL errors at once (syntax errors stop
/// the reading at the first one, as the rest of the file cannot be trusted). A deck with a
/// top-level [fabric] table is a fabric deck; any other is a model deck.
Model read_deck(const std::filesystem::path& file);

/// The TOML table of a deck file, before any key is checked. Throws InputError for a file that
/// does not exist or is not a regular file, and for a syntax error ("file:line:col: syntax
/// error: ...").
toml::table parse_deck_file(const std::filesystem::path& file);

/// As read_deck, from text; `source_name` stands for the file name in messages (for tests), and
/// its folder is where the relative paths of the deck (a fabric deck's `texgen`) start.
Model read_deck_string(std::string_view text, std::string_view source_name);

} // namespace yarnsim
