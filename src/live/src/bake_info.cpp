#include "bake_info.hpp"

#include <fstream>
#include <iterator>

namespace skylit::live {

BakeInfo::BakeInfo(std::filesystem::path bake_dir, bake_format::Manifest manifest, std::filesystem::path site_file)
    : dir_(std::move(bake_dir)), manifest_(std::move(manifest)), site_file_(std::move(site_file)) {}

nlohmann::json BakeInfo::report() {
  nlohmann::json j;
  const bake_format::Plan& plan = manifest_.plan;
  j["bake"] = dir_.string();
  j["site"] = site_file_.string();
  j["made_for"] = {{"site_file", plan.site_file},  {"frequency", plan.frequency},
                   {"basis", std::string(geom::basis_name(plan.basis))}, {"samples", plan.samples},
                   {"method", plan.method},        {"preset", plan.preset},
                   {"layers", manifest_.layer_count()}, {"faces", manifest_.faces.size()}};
  j["generator"] = manifest_.generator;
  j["created_utc"] = manifest_.created_utc;
  j["bake_seconds"] = manifest_.bake_seconds;
  nlohmann::json planes = nlohmann::json::array();
  for (const auto& record : manifest_.planes) {
    const geom::Plane& p = record.plane;
    planes.push_back({{"name", p.name},
                      {"resolution", {p.width, p.height}},
                      {"size_m", {p.u.norm(), p.v.norm()}},
                      {"preview", std::filesystem::is_regular_file(dir_ / "preview" / (p.name + ".png"))
                                      ? nlohmann::json("/bake/preview/" + p.name + ".png")
                                      : nlohmann::json(nullptr)}});
  }
  j["planes"] = planes;
  std::lock_guard lock(mutex_);
  if (!verified_) {
    // Every file's size and SHA-256 against the manifest: as `skylit-bake verify` does.
    const bake_format::VerifyReport verify = bake_format::verify(dir_);
    verified_ = nlohmann::json{{"ok", verify.ok}, {"problems", verify.problems}};
  }
  j["verify"] = *verified_;
  return j;
}

std::vector<std::uint8_t> BakeInfo::preview(const std::string& name) const {
  std::ifstream in(dir_ / "preview" / (name + ".png"), std::ios::binary);
  if (!in) return {};
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace skylit::live
