// libFuzzer target: the TexGen .tg3 reader on arbitrary text (scripts/fuzz), read as written and
// with weaves rebuilt from their pattern.
//
// The contract (engine/textile/texgen.hpp): bad input throws InputError listing every problem as
// "file:line:col: message". Besides crashes and sanitizer reports, any other exception escaping
// read_texgen_string is a finding.

#include "engine/model/deck.hpp"
#include "engine/textile/texgen.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string_view>
#include <typeinfo>

namespace {

void read(std::string_view text, bool rebuild_weaves) {
  yarnsim::textile::TexGenOptions options;
  options.material.young = 73e9; // glass, as the sample-file tests
  options.material.poisson = 0.2;
  options.material.density = 2540;
  options.rebuild_weaves = rebuild_weaves;
  try {
    const yarnsim::textile::Fabric fabric =
        yarnsim::textile::read_texgen_string(text, "fuzz.tg3", options);
    (void)fabric;
  } catch (const yarnsim::InputError&) {
    // Expected for bad input.
  } catch (const std::exception& e) {
    std::fprintf(stderr,
                 "read_texgen_string (rebuild_weaves = %d) threw %s instead of "
                 "InputError: %s\n",
                 int(rebuild_weaves), typeid(e).name(), e.what());
    std::abort();
  }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  read(text, false);
  read(text, true);
  return 0;
}
