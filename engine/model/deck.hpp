#pragma once
// Bad input: the error every reader of a deck or of a file it names throws (InputError). The model
// deck's reader is model_deck.hpp (its schema is declared in deck.cpp), the front door that reads
// any deck engine/input/read_deck.hpp; the format is documented in docs/input.md.

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

} // namespace yarnsim
