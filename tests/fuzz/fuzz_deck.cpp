// libFuzzer target: the TOML deck reader on arbitrary text (scripts/fuzz).
//
// The contract (engine/input/read_deck.hpp): bad input throws InputError, which main() maps to exit
// code 2 with file:line:col messages. So besides crashes and sanitizer reports, any other
// exception escaping read_deck_string is a finding: the command line would report it as an
// internal failure (exit 1) without saying where the deck is wrong.

#include "engine/input/read_deck.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string_view>
#include <typeinfo>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const yarnsim::Model model = yarnsim::read_deck_string(text, "fuzz.toml");
    (void)model;
  } catch (const yarnsim::InputError&) {
    // Expected for bad input.
  } catch (const std::exception& e) {
    std::fprintf(stderr, "read_deck_string threw %s instead of InputError: %s\n", typeid(e).name(),
                 e.what());
    std::abort();
  }
  return 0;
}
