#pragma once
// The picture an installer looks at (the paper's figure 10): the sky frame, the dome drawn on
// it, each face tinted by its luminance parameter, unseen faces hatched, the sun circled.
#include <opencv2/core/mat.hpp>

#include "skylit/geom/dome.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/sky_estimate.hpp"

namespace skylit::sky {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// `radiance`: the linear frame (CV_32FC3 BGR) the estimate came from. Returns CV_8UC3 BGR.
cv::Mat draw_sky_overlay(const camera::Lens& lens, const geom::Dome& dome, const cv::Mat& radiance,
                         const SkyEstimate& estimate);

}  // namespace skylit::sky
