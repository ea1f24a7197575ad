// A sky message from the broker (sky_link::decode_sky_message), CBOR from anyone who can
// publish: a taken sky has finite values and every array the size its identity says.
#include <cmath>

#include "fuzz_target.hpp"
#include "skylit/sky_link/sky_message.hpp"

SKYLIT_FUZZ_TARGET(sky_message) {
  skylit::sky_link::SkyIdentity identity;
  identity.site = "sample gate";
  identity.dome_frequency = 2;
  identity.basis = skylit::geom::DomeBasis::Faces;
  identity.layers = 80;
  const auto decoded = skylit::sky_link::decode_sky_message({data, size}, identity, std::nullopt);
  skylit::fuzz::require(decoded.message.has_value() == (decoded.dropped == skylit::sky_link::DropReason::None),
                        "a sky is taken or dropped with a reason");
  if (decoded.message) {
    skylit::fuzz::require(std::isfinite(decoded.message->frame_timestamp), "a taken sky's time is finite");
  }
  (void)skylit::sky_link::decode_sky_message({data, size}, identity, skylit::sky_link::SkyOrder{5, 1});
  return 0;
}
