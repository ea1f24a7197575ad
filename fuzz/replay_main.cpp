// skylit-fuzz-replay TARGET PATH...: runs every file under PATH (folders recursively, in name
// order) through harness TARGET once, as libFuzzer would, without libFuzzer. `make test` replays
// fuzz/corpus/TARGET this way, so a crash once found and kept there stays fixed.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <vector>

#define SKYLIT_FUZZ_DECLARE(name) int skylit_fuzz_##name(const std::uint8_t* data, std::size_t size);
#include "targets.def"  // written by fuzz/CMakeLists.txt from its list of harnesses
SKYLIT_FUZZ_TARGETS(SKYLIT_FUZZ_DECLARE)

namespace fs = std::filesystem;

namespace {

using Harness = int (*)(const std::uint8_t*, std::size_t);
struct NamedHarness {
  std::string_view name;
  Harness run;
};

#define SKYLIT_FUZZ_ENTRY(name) NamedHarness{#name, &skylit_fuzz_##name},
constexpr NamedHarness kHarnesses[] = {SKYLIT_FUZZ_TARGETS(SKYLIT_FUZZ_ENTRY)};

std::vector<fs::path> inputs_under(const fs::path& path) {
  std::vector<fs::path> files;
  if (fs::is_directory(path)) {
    for (const auto& entry : fs::recursive_directory_iterator(path)) {
      if (entry.is_regular_file()) files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
  } else {
    files.push_back(path);
  }
  return files;
}

}  // namespace

int main(int argc, char** argv) {
  const auto* harness = argc >= 3 ? std::find_if(std::begin(kHarnesses), std::end(kHarnesses),
                                                 [&](const NamedHarness& h) { return h.name == argv[1]; })
                                  : std::end(kHarnesses);
  if (harness == std::end(kHarnesses)) {
    std::fprintf(stderr, "usage: skylit-fuzz-replay TARGET PATH...\ntargets:");
    for (const NamedHarness& h : kHarnesses) std::fprintf(stderr, " %.*s", int(h.name.size()), h.name.data());
    std::fprintf(stderr, "\n");
    return 2;
  }
  std::size_t count = 0;
  for (int i = 2; i < argc; ++i) {
    if (!fs::exists(argv[i])) {
      std::fprintf(stderr, "skylit-fuzz-replay: %s does not exist\n", argv[i]);
      return 2;
    }
    for (const fs::path& file : inputs_under(argv[i])) {
      std::ifstream in(file, std::ios::binary);
      const std::vector<char> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
      // Named before it runs: a crash's output ends with the input that caused it.
      std::printf("%s (%zu bytes)\n", file.c_str(), bytes.size());
      std::fflush(stdout);
      try {
        harness->run(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
      } catch (const std::exception& e) {
        std::fprintf(stderr, "%s: escaped the parser: %s\n", file.c_str(), e.what());
        return 1;
      }
      ++count;
    }
  }
  std::printf("%.*s: %zu inputs replayed, none crashed\n", int(harness->name.size()), harness->name.data(), count);
  return 0;
}
