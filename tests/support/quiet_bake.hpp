#pragma once
// A site baked for a test fixture: ray-traced (the reference engine, and the fast one without a
// GPU), no previews, nothing printed. `adjust` sets any other option (frequency, basis, ...).
#include <filesystem>
#include <functional>

#include "skylit/baker/bake_job.hpp"

namespace skylit::test {

inline void quiet_bake(const std::filesystem::path& site_file, const std::filesystem::path& out_dir, int samples = 4,
                       const std::function<void(baker::BakeOptions&)>& adjust = {}) {
  baker::BakeOptions options;
  options.site_file = site_file;
  options.out_dir = out_dir;
  options.samples = samples;
  options.method = "raytrace";
  options.previews = false;
  if (adjust) adjust(options);
  baker::run_bake(options, nullptr);
}

}  // namespace skylit::test
