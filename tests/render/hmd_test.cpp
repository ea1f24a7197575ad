// The HMD display: profiles from YAML, the lens-correction mesh against its exact CPU reference,
// a straight line bent as the radial model says, the colour channels of a white dot separated
// as the per-channel lenses say, and two eye images side by side. Measured figures are printed
// ("measured:" lines).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "../support/gl_suite.hpp"
#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/render/hmd_distortion.hpp"
#include "skylit/render/hmd_profile.hpp"

namespace skylit::render {
namespace {

namespace fs = std::filesystem;

const fs::path kConfigDir = fs::path(SKYLIT_SOURCE_DIR) / "config" / "hmd";

// A small side-by-side HMD (240 × 200 per eye) with the generic profile's kind of lens.
HmdProfile small_hmd() {
  HmdProfile p;
  p.name = "small";
  p.panel_width = 480;
  p.panel_height = 200;
  p.layout = PanelLayout::side_by_side;
  p.lens_center = {Eigen::Vector2d(124, 98), Eigen::Vector2d(116, 98)};
  p.lens_radius = 120;
  p.distortion = {RadialDistortion{0.20, 0.20, 0.0}, RadialDistortion{0.22, 0.24, 0.0}, RadialDistortion{0.24, 0.28, 0.0}};
  return p;
}

// ---- profiles ----

TEST(HmdProfile, TheShippedProfilesLoad) {
  const HmdProfile generic = load_hmd_profile(kConfigDir / "generic.yaml");
  EXPECT_EQ(generic.layout, PanelLayout::side_by_side);
  EXPECT_EQ(generic.panel_width, 3840);
  EXPECT_EQ(generic.panel_height, 1080);
  EXPECT_EQ(generic.eye_width(), 1920);
  EXPECT_EQ(generic.eye_left(1), 1920);
  EXPECT_DOUBLE_EQ(generic.ipd, 0.064);
  EXPECT_DOUBLE_EQ(generic.lens_radius, 960);
  EXPECT_EQ(generic.lens_center[1], Eigen::Vector2d(960, 540));
  EXPECT_TRUE(generic.has_distortion());
  EXPECT_DOUBLE_EQ(generic.distortion[0].k1, 0.20);   // red
  EXPECT_DOUBLE_EQ(generic.distortion[2].k2, 0.28);   // blue

  const HmdProfile desktop = load_hmd_profile(kConfigDir / "desktop.yaml");
  EXPECT_EQ(desktop.layout, PanelLayout::single);
  EXPECT_EQ(desktop.eye_count(), 1);
  EXPECT_FALSE(desktop.has_distortion());
  // Without a lens, a panel point shows the image point under it.
  const Eigen::Vector2d uv = eye_image_coordinate(desktop, 0, 1, Eigen::Vector2d(320, 180), 1280, 720);
  EXPECT_NEAR(uv.x(), 0.25, 1e-12);
  EXPECT_NEAR(uv.y(), 0.25, 1e-12);
}

class BadProfile : public ::testing::Test {
 protected:
  // The message of the InputError that loading `text` raises.
  std::string error_of(const std::string& text) {
    const fs::path file = dir_.write("bad_hmd.yaml", text);
    try {
      load_hmd_profile(file);
    } catch (const InputError& e) {
      return e.what();
    }
    return "(no InputError)";
  }
  test::TempDir dir_;
};

const std::string kGood = "name: x\npanel: {width: 400, height: 200}\nlayout: side-by-side\n";

TEST_F(BadProfile, EveryMistakeNamesTheFileTheFieldAndTheFix) {
  struct Case {
    std::string text, field, hint;
  };
  const std::vector<Case> cases = {
      {kGood + "ipdd: 0.06\n", "ipdd", "did you mean 'ipd'"},
      {kGood + "ipd: 64\n", "ipd", "0.064"},
      {"name: x\nlayout: single\n", "panel", "add it"},
      {"name: x\npanel: {width: 401, height: 200}\nlayout: side-by-side\n", "panel.width", "even"},
      {kGood + "lens: {left_center: [300, 100]}\n", "lens.left_center", "200 × 200"},
      {kGood + "lens: {red: [0.1, 0.2]}\n", "lens.red", "k1, k2, k3"},
      {kGood + "lens: {center: [100, 100]}\n", "lens.center", "left_center and right_center"},
      {kGood + "layout: stereo\n", "layout", ""},
      {"name: x\npanel: {width: 400, height: 200}\nlayout: stereo\n", "layout", "side-by-side"},
      {kGood + "fov_deg: 200\n", "fov_deg", "180"},
      {kGood + "lens: {red: [-0.5, 0, 0]}\n", "lens.red", "fold"},
  };
  for (const Case& c : cases) {
    const std::string message = error_of(c.text);
    EXPECT_NE(message.find("bad_hmd.yaml"), std::string::npos) << message;
    EXPECT_NE(message.find("'" + c.field + "'"), std::string::npos) << c.field << ": " << message;
    EXPECT_NE(message.find(c.hint), std::string::npos) << c.hint << ": " << message;
  }
}

// ---- the mapping ----

TEST(HmdMapping, PanelPointOfInvertsTheRadialModel) {
  const HmdProfile hmd = small_hmd();
  for (int eye = 0; eye < 2; ++eye) {
    for (int c = 0; c < 3; ++c) {
      for (const Eigen::Vector2d& p : {Eigen::Vector2d(10.5, 20.5), Eigen::Vector2d(200, 150), Eigen::Vector2d(124, 98)}) {
        const Eigen::Vector2d uv = eye_image_coordinate(hmd, eye, c, p, 320, 240);
        const auto back = panel_point_of(hmd, eye, c, uv, 320, 240);
        ASSERT_TRUE(back.has_value());
        EXPECT_LT((*back - p).norm(), 1e-6) << eye << " " << c;
      }
    }
  }
}

// The largest departure of the mesh's linear interpolation from the exact mapping, over the
// cells' centres where the image is shown, in pixels of a 1920 × 1080 eye image.
double mesh_error(const HmdProfile& profile, int grid) {
  const int w = 1920, h = 1080;
  const std::vector<DistortionVertex> mesh = make_distortion_mesh(profile, 1, w, h, grid);
  EXPECT_EQ(mesh.size(), static_cast<std::size_t>((grid + 1) * (grid + 1)));
  double worst = 0;
  for (int row = 0; row < grid; ++row) {
    for (int col = 0; col < grid; ++col) {
      // Each cell is cut along its diagonal from the top-right to the bottom-left vertex: the
      // cell's centre is that diagonal's midpoint, where the interpolation is farthest from them.
      const DistortionVertex& a = mesh[static_cast<std::size_t>(row * (grid + 1) + col + 1)];
      const DistortionVertex& d = mesh[static_cast<std::size_t>((row + 1) * (grid + 1) + col)];
      for (int c = 0; c < 3; ++c) {
        const Eigen::Vector2d mid(0.5 * (a.x + d.x) - profile.eye_left(1), 0.5 * (a.y + d.y));
        const Eigen::Vector2d exact = eye_image_coordinate(profile, 1, c, mid, w, h);
        const Eigen::Vector2d interpolated(0.5 * (a.uv[2 * c] + d.uv[2 * c]), 0.5 * (a.uv[2 * c + 1] + d.uv[2 * c + 1]));
        const Eigen::Vector2d error = (exact - interpolated).cwiseProduct(Eigen::Vector2d(w, h));
        if (exact.minCoeff() >= 0 && exact.x() <= 1 && exact.y() <= 1) worst = std::max(worst, error.norm());
      }
    }
  }
  return worst;
}

TEST(HmdMapping, TheMeshErrorFallsAsTheSquareOfTheGrid) {
  // The GPU interpolates the mapping linearly between mesh vertices. On the generic profile the
  // lens bends hardest where the image ends (r ≈ 0.8), so a 40 × 40 mesh is off by up to ~1.7
  // image pixels there; the default grid (HmdDistortionOptions) keeps it under a quarter pixel.
  const HmdProfile generic = load_hmd_profile(kConfigDir / "generic.yaml");
  const int fine = HmdDistortionOptions{}.grid;
  const double coarse_error = mesh_error(generic, 40), fine_error = mesh_error(generic, fine);
  std::printf("measured: mesh vs exact mapping, generic profile: max %.3f px at 40x40, %.3f px at %dx%d\n",
              coarse_error, fine_error, fine, fine);
  EXPECT_LT(coarse_error, 2.0);
  EXPECT_GT(coarse_error, 0.5);   // the mapping is not linear: a zero would mean the mesh is not tested
  EXPECT_LT(fine_error, 0.25);
  const double expected_ratio = (static_cast<double>(fine) / 40) * (static_cast<double>(fine) / 40);
  EXPECT_NEAR(coarse_error / fine_error, expected_ratio, 0.25 * expected_ratio);
}

// ---- the GPU pass ----

class HmdDistortionGpu : public skylit::test::GlSuite {};

// A smooth, coloured test image (no channel equal to another), different for each seed.
cv::Mat smooth_image(int width, int height, double seed) {
  cv::Mat image(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double u = static_cast<double>(x) / width, v = static_cast<double>(y) / height;
      image.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<std::uint8_t>(128 + 100 * std::sin(9 * u + 4 * v + seed)),
                                            cv::saturate_cast<std::uint8_t>(128 + 100 * std::cos(7 * v - 3 * u + seed)),
                                            cv::saturate_cast<std::uint8_t>(40 + 180 * u * v));
    }
  }
  return image;
}

TEST_F(HmdDistortionGpu, MatchesTheExactMappingOnTheCpu) {
  const HmdProfile hmd = small_hmd();
  const std::vector<cv::Mat> eyes = {smooth_image(320, 240, 0.0), smooth_image(320, 240, 1.7)};
  const gpu::Texture left = upload_eye_image(eyes[0]), right = upload_eye_image(eyes[1]);
  HmdDistortion pass(hmd);
  const std::vector<GLuint> textures = {left.get(), right.get()};
  pass.draw(textures, 320, 240);
  const cv::Mat gpu_panel = pass.read_panel();
  const cv::Mat cpu_panel = distort_reference(hmd, eyes);
  ASSERT_EQ(gpu_panel.size(), cpu_panel.size());

  // Compare every channel of every pixel whose coordinate lies more than 1.5 image pixels inside
  // the image (at the image's outline a pixel is black or not by a hair's breadth).
  int worst = 0, compared = 0, black = 0;
  for (int eye = 0; eye < 2; ++eye) {
    for (int y = 0; y < hmd.eye_height(); ++y) {
      for (int x = 0; x < hmd.eye_width(); ++x) {
        const int panel_x = x + hmd.eye_left(eye);
        for (int c = 0; c < 3; ++c) {
          const Eigen::Vector2d uv = eye_image_coordinate(hmd, eye, c, Eigen::Vector2d(x + 0.5, y + 0.5), 320, 240);
          const double ix = uv.x() * 320, iy = uv.y() * 240;
          const bool inside = ix > 1.5 && ix < 318.5 && iy > 1.5 && iy < 238.5;
          const bool outside = ix < -1.5 || ix > 321.5 || iy < -1.5 || iy > 241.5;
          const int g = gpu_panel.at<cv::Vec3b>(y, panel_x)[2 - c], r = cpu_panel.at<cv::Vec3b>(y, panel_x)[2 - c];
          if (inside) {
            worst = std::max(worst, std::abs(g - r));
            ++compared;
          } else if (outside) {
            EXPECT_EQ(g, 0) << "eye " << eye << " (" << x << ", " << y << ") channel " << c;
            ++black;
          }
        }
      }
    }
  }
  std::printf("measured: distortion pass vs CPU reference: max %d codes over %d channel values (%d black outside)\n",
              worst, compared, black);
  EXPECT_GT(compared, 150000);
  EXPECT_GT(black, 10000);  // the barrel leaves the corners black
  EXPECT_LE(worst, 2);
}

// The centroid along y of channel `c` (BGR index) of `panel` in column x, over rows y0 ± 12.
double column_centroid(const cv::Mat& panel, int x, double y0, int c) {
  double sum = 0, weighted = 0;
  for (int y = std::max(0, static_cast<int>(y0) - 12); y <= std::min(panel.rows - 1, static_cast<int>(y0) + 12); ++y) {
    const double value = panel.at<cv::Vec3b>(y, x)[c];
    sum += value;
    weighted += value * (y + 0.5);
  }
  return sum > 0 ? weighted / sum : -1;
}

TEST_F(HmdDistortionGpu, AStraightLineBendsAsTheRadialModelSays) {
  const HmdProfile hmd = small_hmd();
  const int w = 320, h = 240, line_row = 50;  // a white line across the image, above the centre
  cv::Mat image(h, w, CV_8UC3, cv::Scalar::all(0));
  image.rowRange(line_row - 1, line_row + 2).setTo(cv::Scalar::all(255));
  const gpu::Texture texture = upload_eye_image(image);
  HmdDistortion pass(hmd);
  const GLuint name = texture.get();
  pass.draw(std::span<const GLuint>(&name, 1), w, h);
  const cv::Mat panel = pass.read_panel();

  // For panel columns across the left eye: the row where the green lens shows the line's centre
  // (line_row + 0.5 image pixels), solved from the radial model, and the centroid of the green
  // channel in that column as displayed.
  double worst = 0, centre_row = 0, edge_row = 0;
  const double v = (line_row + 0.5) / h;
  for (const int x : {40, 70, 124, 170, 200}) {
    double lo = 0, hi = hmd.lens_center[0].y();  // above the centre the source row rises with y
    for (int i = 0; i < 50; ++i) {
      const double mid = 0.5 * (lo + hi);
      (eye_image_coordinate(hmd, 0, 1, Eigen::Vector2d(x + 0.5, mid), w, h).y() < v ? lo : hi) = mid;
    }
    const double predicted = 0.5 * (lo + hi);
    const double measured = column_centroid(panel, x, predicted, 1);
    worst = std::max(worst, std::abs(measured - predicted));
    if (x == 124) centre_row = measured;
    if (x == 40) edge_row = measured;
  }
  std::printf("measured: straight line through the lens: rows %.2f (middle) and %.2f (side), worst %.3f px off the model\n",
              centre_row, edge_row, worst);
  EXPECT_LT(worst, 0.25);
  // Barrel: the line's ends come towards the lens centre (row 98), by several pixels.
  EXPECT_GT(edge_row - centre_row, 3.0);
}

TEST_F(HmdDistortionGpu, RedAndBlueOfAWhiteDotSeparateAsTheLensesSay) {
  const HmdProfile hmd = small_hmd();
  const int w = 320, h = 240;
  cv::Mat image(h, w, CV_8UC3, cv::Scalar::all(0));
  const int dot_x = 295, dot_y = 220;  // toward the lower right, where the channels part most
  image(cv::Rect(dot_x - 1, dot_y - 1, 3, 3)).setTo(cv::Scalar::all(255));
  const gpu::Texture texture = upload_eye_image(image);
  HmdDistortion pass(hmd);
  const GLuint name = texture.get();
  pass.draw(std::span<const GLuint>(&name, 1), w, h);
  const cv::Mat panel = pass.read_panel();

  const Eigen::Vector2d uv((dot_x + 0.5) / w, (dot_y + 0.5) / h);
  const int eye = 1;
  const auto red = panel_point_of(hmd, eye, 0, uv, w, h), blue = panel_point_of(hmd, eye, 2, uv, w, h);
  ASSERT_TRUE(red && blue);
  auto centroid = [&](const Eigen::Vector2d& near, int bgr) {
    Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
    double sum = 0;
    for (int y = static_cast<int>(near.y()) - 8; y <= static_cast<int>(near.y()) + 8; ++y) {
      for (int x = static_cast<int>(near.x()) - 8; x <= static_cast<int>(near.x()) + 8; ++x) {
        const double value = panel.at<cv::Vec3b>(y, x + hmd.eye_left(eye))[bgr];
        sum += value;
        weighted += value * Eigen::Vector2d(x + 0.5, y + 0.5);
      }
    }
    return Eigen::Vector2d(weighted / sum);
  };
  const Eigen::Vector2d red_seen = centroid(*red, 2), blue_seen = centroid(*blue, 0);
  const Eigen::Vector2d predicted = *red - *blue, seen = red_seen - blue_seen;
  std::printf("measured: red-blue separation of a white dot: predicted (%.2f, %.2f) px, displayed (%.2f, %.2f) px\n",
              predicted.x(), predicted.y(), seen.x(), seen.y());
  EXPECT_GT(predicted.norm(), 2.0);  // the lenses differ enough for the test to mean something
  EXPECT_LT((seen - predicted).norm(), 0.3);
  EXPECT_LT((red_seen - *red).norm(), 0.3);
  EXPECT_LT((blue_seen - *blue).norm(), 0.3);
}

TEST_F(HmdDistortionGpu, EachEyeShowsItsOwnImageSideBySide) {
  HmdProfile hmd = small_hmd();
  hmd.distortion = {};  // no lens: each half is its eye's image fitted to it
  cv::Mat red(100, 120, CV_8UC3, cv::Scalar(0, 0, 255)), blue(100, 120, CV_8UC3, cv::Scalar(255, 0, 0));
  const gpu::Texture left = upload_eye_image(red), right = upload_eye_image(blue);
  HmdDistortion pass(hmd);
  const std::vector<GLuint> textures = {left.get(), right.get()};
  pass.draw(textures, 120, 100);
  const cv::Mat panel = pass.read_panel();
  EXPECT_EQ(panel.at<cv::Vec3b>(98, 124), cv::Vec3b(0, 0, 255));        // left lens centre: red
  EXPECT_EQ(panel.at<cv::Vec3b>(98, 240 + 116), cv::Vec3b(255, 0, 0));  // right lens centre: blue
  // The 120 × 100 image fitted to 240 × 200 fills the height; centred on the left lens (x 124) it
  // spans x 4 .. 244, so the left eye's first columns are black.
  EXPECT_EQ(panel.at<cv::Vec3b>(98, 1), cv::Vec3b(0, 0, 0));
}

}  // namespace
}  // namespace skylit::render
