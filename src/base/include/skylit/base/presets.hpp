#pragma once
// The presets file (config/presets.yaml, docs/presets.md): named settings, one section per layer
// they configure (bake:, live:). This reads the file's shape; each layer types its own section
// (baker/preset.hpp, live/live_config.hpp).
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "skylit/base/yaml_reader.hpp"

namespace skylit {

// The presets the tools use when none is given: presets.yaml in data_dir() (config/presets.yaml
// of the source tree, copied there by the build and installed there).
std::filesystem::path default_presets_file();

// One section of one preset, with the reader that names the file, line and field in errors.
struct PresetSection {
  YamlReader reader;
  YAML::Node node;        // a map (every preset has every section)
  std::string field;      // "balanced.bake": the prefix of the section's fields in messages
  // "balanced.bake.frequency"
  std::string field_of(std::string_view key) const { return field + "." + std::string(key); }
};

class PresetsFile {
 public:
  // Parses `file`: a map of names, each {bake: {...}, live: {...}}. InputError (file, line, field,
  // fix) for anything else, or for a file without presets.
  explicit PresetsFile(std::filesystem::path file);

  const std::filesystem::path& file() const { return reader_.file(); }
  // In file order.
  const std::vector<std::string>& names() const { return names_; }
  // "fast, balanced, accurate".
  std::string names_text() const;

  // Section `section` ("bake" or "live") of preset `name`; InputError naming the file and the
  // valid names when there is no such preset.
  PresetSection section(const std::string& name, std::string_view section) const;

 private:
  YamlReader reader_;
  YAML::Node root_;
  std::vector<std::string> names_;
};

}  // namespace skylit
