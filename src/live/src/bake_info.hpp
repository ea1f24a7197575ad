#pragma once
// The console's bake view (docs/console.md): what the bake was made for, its planes and their
// previews, and its verify result (checked once, on the first request, then kept).
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "skylit/bake_format/manifest.hpp"

namespace skylit::live {

class BakeInfo {
 public:
  BakeInfo(std::filesystem::path bake_dir, bake_format::Manifest manifest, std::filesystem::path site_file);
  nlohmann::json report();                                  // thread-safe
  std::vector<std::uint8_t> preview(const std::string& name) const;  // PNG bytes; empty when there is none

 private:
  std::filesystem::path dir_;
  bake_format::Manifest manifest_;
  std::filesystem::path site_file_;
  std::mutex mutex_;
  std::optional<nlohmann::json> verified_;
};

}  // namespace skylit::live
