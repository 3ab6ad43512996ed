#pragma once
// Decks as text, for tests that run an example with a key or two changed: the example's text and
// a key's value replaced (read_deck_string then reads it as the file would be read).

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace yarnsim::test {

/// The text of examples/<name> in the source tree. Throws std::runtime_error where it cannot be
/// read.
inline std::string example_text(const std::string& name) {
  const std::filesystem::path path = std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples" / name;
  std::ifstream in(path);
  if (!in)
    throw std::runtime_error("cannot read " + path.string());
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// Replaces the first line "key = ..." after a line break in `deck` by "key = value" (the line's
/// comment too); false, and `deck` unchanged, where there is no such line.
inline bool set_key(std::string& deck, const std::string& key, const std::string& value) {
  const std::size_t at = deck.find("\n" + key + " = ");
  if (at == std::string::npos)
    return false;
  const std::size_t end = deck.find('\n', at + 1);
  deck.replace(at + 1, (end == std::string::npos ? deck.size() : end) - at - 1,
               key + " = " + value);
  return true;
}

} // namespace yarnsim::test
