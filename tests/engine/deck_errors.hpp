#pragma once
// What a deck that does not read reports, for the deck tests (model, fabric and TexGen decks).

#include "engine/input/read_deck.hpp"

#include <gtest/gtest.h>
#include <string>
#include <string_view>
#include <vector>

namespace yarnsim::test {

/// The messages of the InputError that reading `deck` as the file `name` throws; a test failure
/// (and no messages) when it reads cleanly.
inline std::vector<std::string> errors_of(std::string_view deck, std::string_view name) {
  try {
    read_deck_string(deck, name);
  } catch (const InputError& e) {
    return e.messages();
  }
  ADD_FAILURE() << "deck read without errors:\n" << deck;
  return {};
}

/// `deck` with the first `from` replaced by `to` (a test failure when `from` is not in it).
inline std::string with(std::string_view deck, std::string_view from, std::string_view to) {
  std::string out(deck);
  const std::size_t at = out.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos)
    out.replace(at, from.size(), to);
  return out;
}

/// Whether one of the messages holds `text`.
inline bool has(const std::vector<std::string>& messages, std::string_view text) {
  for (const auto& m : messages)
    if (m.find(text) != std::string::npos)
      return true;
  return false;
}

/// The messages one per line, for a failure's report.
inline std::string joined(const std::vector<std::string>& messages) {
  std::string out;
  for (const auto& m : messages)
    out += m + "\n";
  return out;
}

} // namespace yarnsim::test
