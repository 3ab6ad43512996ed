#include "engine/input/read_deck.hpp"

#include "engine/model/deck_schema.hpp"
#include "engine/model/model_deck.hpp"
#include "engine/textile/fabric_deck.hpp"

#include <fmt/format.h>
#include <optional>
#include <toml++/toml.h>

namespace yarnsim {

namespace {

/// The deck of either kind; relative paths in it start at `folder`.
Model build(const toml::table& table, deck::Diagnostics& diagnostics,
            const std::filesystem::path& folder) {
  std::optional<Model> fabric = textile::read_fabric_deck(table, diagnostics, folder);
  Model model = fabric ? std::move(*fabric) : read_model_deck(table, diagnostics);
  if (!diagnostics.empty())
    throw InputError(diagnostics.messages());
  return model;
}

} // namespace

toml::table parse_deck_file(const std::filesystem::path& file) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec))
    throw InputError(
        {fmt::format("{}: cannot read the deck: {}", file.string(),
                     std::filesystem::exists(file, ec) ? "not a regular file" : "no such file")});
  try {
    return toml::parse_file(file.string());
  } catch (const toml::parse_error& e) {
    deck::Diagnostics diagnostics(file.string());
    diagnostics.error(e.source(), "", fmt::format("syntax error: {}", e.description()));
    throw InputError(diagnostics.messages());
  }
}

Model read_deck(const std::filesystem::path& file) {
  const toml::table table = parse_deck_file(file);
  deck::Diagnostics diagnostics(file.string());
  return build(table, diagnostics, file.parent_path());
}

Model read_deck_string(std::string_view text, std::string_view source_name) {
  deck::Diagnostics diagnostics{std::string(source_name)};
  toml::table table;
  try {
    table = toml::parse(text, source_name);
  } catch (const toml::parse_error& e) {
    diagnostics.error(e.source(), "", fmt::format("syntax error: {}", e.description()));
    throw InputError(diagnostics.messages());
  }
  return build(table, diagnostics, std::filesystem::path(source_name).parent_path());
}

} // namespace yarnsim
