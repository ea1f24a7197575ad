#pragma once
// A marker map from photos of the site (skylit-calib markers): the AprilTags in every photo, one
// tag fixed as the site's origin, the others placed by chaining photo to photo from it, then a
// joint least-squares refinement of every photo's camera pose and every tag's pose that
// minimises the corners' reprojection error (pixels of the photos, through the calibrated lens).
#include <filesystem>
#include <map>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "skylit/camera/calibration.hpp"
#include "skylit/track/marker_map.hpp"
#include "skylit/track/marker_options.hpp"
#include "skylit/track/pose.hpp"
#include "skylit/track/tag_detector.hpp"

namespace skylit::calib {

// The tags detected in one photo.
struct MarkerPhoto {
  std::string name;  // for messages (the file name)
  std::vector<track::TagDetection> detections;
};

// Reads each photo (any format OpenCV reads, as grey) and detects the tags in it. InputError
// naming a photo that cannot be read or whose size differs from the camera calibration's.
std::vector<MarkerPhoto> detect_marker_photos(std::span<const std::filesystem::path> photos,
                                              const camera::CameraCalibration& camera,
                                              const track::TagDetectorOptions& detector);

// The origin tag fixes the frame (its pose is given, the identity by default: the site's origin
// at its centre, its face up, its top edge north); the tags' printed sizes fix the scale.
// A tag is mapped only when it is seen in at least `min_photos` photos that are themselves posed
// from mapped tags: a tag seen once has nothing to check it against, and a tag never seen with a
// mapped tag cannot be placed. Those are listed with the reason and what photo would place them.
struct MarkerSurveyOptions {
  std::string family = "tag36h11";
  int origin_id = 0;
  // Where the origin tag is in the site (R_site_from_tag, t_site_from_tag); identity by default.
  track::MarkerTag origin_pose;
  double default_size = 0;          // metres, for tags without an entry in `sizes`
  std::map<int, double> sizes;      // metres, per tag id
  int min_photos = 2;               // photos a tag must be seen in to be mapped
  // Corners further than this from their reprojection (pixels) weigh less, so one misdetected
  // corner does not pull the map: Cauchy's loss (the default) lets a corner 12 px off pull as
  // one 0.3 px off does; Huber's, convex, lets it pull as one `robust_px` off does.
  enum class RobustLoss { Cauchy, Huber };
  RobustLoss loss = RobustLoss::Cauchy;
  double robust_px = 2.0;
  int max_iterations = 100;
  // Advice thresholds.
  double advise_rms_px = 1.0;          // per-tag RMS residual above which the tag is suspect
  double advise_spread_deg = 15.0;     // a tag seen from directions closer than this is poorly fixed in depth
  double advise_sigma_m = 0.01;        // a tag whose position is uncertain by more than this (1σ)
};

struct SurveyedTag {
  int id = 0;
  int photos = 0;             // posed photos in which it was seen
  double rms_px = 0;          // RMS reprojection error of its corners over those photos
  double sigma_position_m = 0;  // 1σ of its position (the three axes together), from the fit
  double sigma_rotation_deg = 0;  // 1σ of its orientation
  double view_spread_deg = 0;  // the widest angle between two directions it was photographed from
  bool origin = false;
};

struct SurveyedPhoto {
  std::string name;
  bool posed = false;
  track::Pose camera;          // the camera in the site, when posed
  double rms_px = 0;           // over the corners of the mapped tags it saw
  std::vector<int> tags;       // mapped tags seen in it
  std::string reason;          // why it is not posed
};

struct LeftOutTag {
  int id = 0;
  int photos = 0;              // photos it was detected in
  std::string reason;          // "seen in 1 photo; ...", "never seen together with a mapped tag; ..."
};

struct MarkerSurvey {
  track::MarkerMap map;                 // the mapped tags, by id; the origin's pose as given
  std::vector<SurveyedTag> tags;        // the same order as map.tags
  std::vector<SurveyedPhoto> photos;    // the order of the input
  std::vector<LeftOutTag> left_out;
  double rms_px = 0;                    // over every corner used
  int corners = 0;                      // corners used
  int iterations = 0;                   // of the joint refinement
  std::vector<std::string> advice;      // what to do when the data are not good enough
};

// InputError (naming the option and the fix) when the options are wrong, the origin tag is in no
// photo, or fewer than two photos can be posed. Tags of unknown size are left out, and so is an
// id found twice in one photo (from that photo; advice says so).
MarkerSurvey survey_markers(std::span<const MarkerPhoto> photos, const camera::CameraCalibration& camera,
                            const MarkerSurveyOptions& options);

// A top-down plan (x east to the right, y north up): each tag as a bar along its printed x axis
// with an arrow for its facing, labelled with its id and residual (green under advise_rms_px,
// red over), each posed camera as a dot with its view direction, lines from cameras to the tags
// they saw; a scale bar in metres.
cv::Mat draw_marker_survey(const MarkerSurvey& survey, const MarkerSurveyOptions& options, int size_px = 900);

}  // namespace skylit::calib
