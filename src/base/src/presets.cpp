#include "skylit/base/presets.hpp"

#include <algorithm>
#include <array>

#include "skylit/base/data_dir.hpp"
#include "skylit/base/error.hpp"

namespace skylit {
namespace {

constexpr const char* kDocs = "see docs/presets.md";
constexpr std::array<std::string_view, 2> kSections{"bake", "live"};

}  // namespace

std::filesystem::path default_presets_file() { return data_dir() / "presets.yaml"; }

PresetsFile::PresetsFile(std::filesystem::path file) : reader_(std::move(file)) {
  root_ = reader_.load();
  reader_.expect_map(root_, "", "a presets file maps each name to {bake: {...}, live: {...}}; " + std::string(kDocs));
  for (const auto& entry : root_) {
    if (!entry.first.IsScalar()) {
      reader_.fail(entry.first, "", "a preset's name must be a plain word, not a list or a map",
                   "name it, e.g. balanced: {bake: ..., live: ...}");
    }
    const std::string name = entry.first.Scalar();
    const YAML::Node node = entry.second;
    reader_.expect_map(node, name, "{bake: {...}, live: {...}}; " + std::string(kDocs));
    reader_.check_keys(node, name + ".", kSections);
    for (const std::string_view section : kSections) {
      const std::string field = name + "." + std::string(section);
      reader_.expect_map(reader_.require(node, std::string(section), field, "the " + std::string(section) + " settings"),
                         field, kDocs);
    }
    names_.push_back(name);
  }
  if (names_.empty()) reader_.fail(root_, "", "no presets", "name at least one, e.g. balanced: {bake: ..., live: ...}");
}

std::string PresetsFile::names_text() const {
  std::string text;
  for (const std::string& name : names_) text += (text.empty() ? "" : ", ") + name;
  return text;
}

PresetSection PresetsFile::section(const std::string& name, std::string_view section) const {
  if (std::find(names_.begin(), names_.end(), name) == names_.end()) {
    throw InputError("preset '" + name + "' is not in " + file().string() + ". Fix: use one of " + names_text());
  }
  return {reader_, root_[name][std::string(section)], name + "." + std::string(section)};
}

}  // namespace skylit
