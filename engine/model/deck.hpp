#pragma once
// The TOML model deck: reading, validation and resolution into a Model. The format is documented
// in docs/input.md; the schema of every block is declared in deck.cpp.

#include "engine/model/model.hpp"

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace yarnsim {

/// Bad input: every problem of a deck, one per line, each "file:line:col: message". main() maps
/// this to exit code 2.
class InputError : public std::runtime_error {
public:
  explicit InputError(std::vector<std::string> messages);
  /// The problems in file order; what() is these joined by newlines.
  const std::vector<std::string>& messages() const { return messages_; }

private:
  std::vector<std::string> messages_;
};

/// Reads and validates a deck; throws InputError listing ALL errors at once (syntax errors stop
/// the reading at the first one, as the rest of the file cannot be trusted).
Model read_deck(const std::filesystem::path& file);

/// As read_deck, from text; `source_name` stands for the file name in messages (for tests), and
/// its folder is where the relative paths of the deck (a fabric deck's `texgen`) start.
Model read_deck_string(std::string_view text, std::string_view source_name);

} // namespace yarnsim
