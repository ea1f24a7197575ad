#pragma once
// A fuzz harness feeds one parser of outside input arbitrary bytes. `make fuzz` links each with
// libFuzzer; the normal build links them all into skylit-fuzz-replay, which replays fuzz/corpus.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string_view>

#include "skylit/base/error.hpp"

#if defined(SKYLIT_LIBFUZZER)
#define SKYLIT_FUZZ_TARGET(name) extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
#else
#define SKYLIT_FUZZ_TARGET(name) int skylit_fuzz_##name(const std::uint8_t* data, std::size_t size)
#endif

namespace skylit::fuzz {

// This process's scratch directory under TMPDIR: made on first use, removed at exit.
const std::filesystem::path& scratch_dir();

// Writes the input to scratch_dir()/name (replacing it) and returns that path.
std::filesystem::path write_input(std::string_view name, const std::uint8_t* data, std::size_t size);

// A parser may refuse input only with InputError (a message naming the file, field and fix);
// any other exception escapes to libFuzzer, which reports it as a finding.
template <typename Parse>
void refuse_only_with_input_error(Parse&& parse) {
  try {
    parse();
  } catch (const InputError&) {
  }
}

// A property every accepted input must have; aborts (a finding) naming it otherwise.
void require(bool holds, const char* what);

}  // namespace skylit::fuzz
