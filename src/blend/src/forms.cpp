#include "skylit/blend/forms.hpp"

#include <iterator>

namespace skylit::blend {
namespace {

static_assert(std::size(kFormNames) == static_cast<std::size_t>(BasisForm::Cropped) + 1);
static_assert(std::size(kStorageNames) == static_cast<std::size_t>(BasisStorage::Eac11) + 1);

}  // namespace

std::string_view form_name(BasisForm form) { return kFormNames[static_cast<int>(form)]; }

std::optional<BasisForm> parse_form(std::string_view name) {
  for (std::size_t i = 0; i < std::size(kFormNames); ++i) {
    if (kFormNames[i] == name) return static_cast<BasisForm>(i);
  }
  return std::nullopt;
}

std::string_view storage_name(BasisStorage storage) { return kStorageNames[static_cast<int>(storage)]; }

std::optional<BasisStorage> parse_storage(std::string_view name) {
  for (std::size_t i = 0; i < std::size(kStorageNames); ++i) {
    if (kStorageNames[i] == name) return static_cast<BasisStorage>(i);
  }
  return std::nullopt;
}

}  // namespace skylit::blend
