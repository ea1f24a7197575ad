// The quadratics basis in the baker: six layers per face, baked in two passes of three, against a
// faces and a corners bake of the same scene with the same sample directions.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "../support/box_site.hpp"
#include "../support/suite_setup.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/base/error.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/geom/dome_basis.hpp"

namespace skylit::baker {
namespace {

namespace fs = std::filesystem;

class QuadraticsBake : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new skylit::test::TempDir("skylit-quadratics-bake-");
    skylit::test::write_box_site(dir_->path(), "dome:\n  frequency: 2\n  basis: quadratics\n"
                                        "planes:\n"
                                        "  - name: ground\n    origin: [-6, -6, 0.01]\n    u: [12, 0, 0]\n"
                                        "    v: [0, 12, 0]\n    resolution: [48, 48]\n"
                                        "  - name: south\n    origin: [-1, -1.01, 0]\n    u: [2, 0, 0]\n"
                                        "    v: [0, 0, 2]\n    resolution: [8, 8]\n");
    std::FILE* quiet = std::fopen("/dev/null", "w");
    BakeOptions options;
    options.site_file = *dir_ / "site.yaml";
    options.samples = 16;
    options.method = "raytrace";
    options.previews = false;
    options.out_dir = *dir_ / "quadratics";  // the site's basis
    setup_.run([&] {
      run_bake(options, quiet);
      for (const geom::DomeBasis basis : {geom::DomeBasis::Faces, geom::DomeBasis::Corners}) {
        options.out_dir = *dir_ / std::string(geom::basis_name(basis));
        options.basis = basis;
        run_bake(options, quiet);
      }
    });
    std::fclose(quiet);
  }
  void SetUp() override { setup_.require(); }
  static void TearDownTestSuite() {
    delete dir_;
  }
  static bake_format::Manifest manifest(const std::string& name) { return bake_format::read_manifest(*dir_ / name); }
  static bake_format::ImageStack plane(const std::string& name, std::size_t j) {
    return bake_format::read_exr_stack(*dir_ / name / manifest(name).planes[j].file);
  }
  static skylit::test::TempDir* dir_;
  static inline skylit::test::SuiteSetup setup_;
};
skylit::test::TempDir* QuadraticsBake::dir_ = nullptr;

TEST_F(QuadraticsBake, TheBakeHasSixLayersPerFaceAndItsASplitsTheCorners) {
  const bake_format::VerifyReport report = bake_format::verify(*dir_ / "quadratics");
  ASSERT_TRUE(report.ok) << (report.problems.empty() ? "" : report.problems.front());
  EXPECT_EQ(report.manifest.plan.basis, geom::DomeBasis::Quadratics);
  EXPECT_EQ(report.manifest.layer_count(), 240U);
  std::vector<std::size_t> shape;
  bake_format::read_npy(*dir_ / "quadratics" / "transfer.npy", &shape);
  EXPECT_EQ(shape, (std::vector<std::size_t>{report.manifest.plan.vertex_count, 240}));
  const bake_format::ImageStack ground = plane("quadratics", 0);
  EXPECT_EQ(ground.layers, 240);
  const bake_format::Manifest faces = manifest("faces");
  const bake_format::Manifest corners = manifest("corners");
  const Eigen::Matrix<double, 3, 6> to_corner = geom::quadratic_to_corner();
  for (std::size_t j = 0; j < 2; ++j) {
    const auto& a6 = report.manifest.planes[j].unoccluded;
    const auto& a3 = corners.planes[j].unoccluded;
    const auto& a1 = faces.planes[j].unoccluded;
    for (std::size_t i = 0; i < 40; ++i) {
      const Eigen::Map<const Eigen::Matrix<double, 6, 1>> q(&a6[6 * i]);
      EXPECT_NEAR(q.sum(), a1[i], 1e-14);
      const Eigen::Vector3d mapped = to_corner * q;
      for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(mapped[static_cast<Eigen::Index>(k)], a3[3 * i + k], 1e-14);
    }
  }
}

TEST_F(QuadraticsBake, AnUnoccludedTexelHoldsAAndTheFunctionsAddUpToTheFace) {
  const bake_format::Manifest quadratics = manifest("quadratics");
  const bake_format::Manifest faces = manifest("faces");
  for (std::size_t j = 0; j < 2; ++j) {
    SCOPED_TRACE(quadratics.planes[j].plane.name);
    const bake_format::ImageStack b6 = plane("quadratics", j);
    const bake_format::ImageStack b1 = plane("faces", j);
    const std::size_t texels = static_cast<std::size_t>(b1.width * b1.height);
    double sum_diff = 0, total_a = 0;
    int shadowed = 0;
    for (int i = 0; i < 40; ++i) {
      total_a += faces.planes[j].unoccluded[static_cast<std::size_t>(i)];
      for (std::size_t t = 0; t < texels; ++t) {
        double sum = 0;
        for (int k = 0; k < 6; ++k) {
          const double ak = quadratics.planes[j].unoccluded[static_cast<std::size_t>(6 * i + k)];
          const double b = b6.layer(6 * i + k)[t];
          ASSERT_GE(b, 0.0);
          ASSERT_LE(b, ak * (1 + 1e-3) + 1e-7);  // visibility ≤ 1 in every function
          shadowed += k >= 3 && b < 0.5 * ak;  // a layer of the second pass in shadow
          sum += b;
        }
        sum_diff += std::abs(sum - b1.layer(i)[t]);
      }
    }
    // Σ_k B_{f,k} is the faces bake's B_f up to how well the 16 samples' weights estimate each
    // function's share of A (the same directions in every bake).
    EXPECT_LT(sum_diff / static_cast<double>(texels) / total_a, 4e-3);
    if (j == 0) {
      EXPECT_GT(shadowed, 100);  // the box shadows the ground in the second pass's layers too
    }
  }
  // The south plane sees all of its half of the sky: B = A in every layer, both passes.
  const bake_format::ImageStack south = plane("quadratics", 1);
  int lit_layers = 0;
  for (int l = 0; l < 240; ++l) {
    const double a = quadratics.planes[1].unoccluded[static_cast<std::size_t>(l)];
    lit_layers += a > 0.0;
    for (float b : south.layer(l)) ASSERT_NEAR(b, a, 5e-4 * a + 1e-8) << "layer " << l;
  }
  EXPECT_GT(lit_layers, 60);
}

TEST_F(QuadraticsBake, TransferVectorsSplitTheFacesTransfer) {
  std::vector<std::size_t> shape6, shape1;
  const std::vector<float> t6 = bake_format::read_npy(*dir_ / "quadratics" / "transfer.npy", &shape6);
  const std::vector<float> t1 = bake_format::read_npy(*dir_ / "faces" / "transfer.npy", &shape1);
  const std::size_t vertices = shape1.at(0);
  ASSERT_EQ(shape6, (std::vector<std::size_t>{vertices, 240}));
  double diff = 0, total = 0;
  for (std::size_t v = 0; v < vertices; ++v) {
    for (std::size_t i = 0; i < 40; ++i) {
      double sum = 0;
      for (std::size_t k = 0; k < 6; ++k) sum += t6[v * 240 + 6 * i + k];
      diff += std::abs(sum - t1[v * 40 + i]);
      total += t1[v * 40 + i];
    }
  }
  EXPECT_GT(total, 0.0);
  EXPECT_LT(diff / total, 1e-5);
}

TEST_F(QuadraticsBake, FewerThanSixSamplesAreRefused) {
  BakeOptions options;
  options.site_file = *dir_ / "site.yaml";
  options.out_dir = *dir_ / "refused";
  options.samples = 4;
  options.method = "raytrace";
  std::FILE* quiet = std::fopen("/dev/null", "w");
  try {
    run_bake(options, quiet);
    ADD_FAILURE() << "a quadratics bake with four samples per face was accepted";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("--samples"), std::string::npos) << message;
    EXPECT_NE(message.find("dome.basis: quadratics"), std::string::npos) << message;
    EXPECT_NE(message.find("at least 6"), std::string::npos) << message;
  }
  std::fclose(quiet);
}

}  // namespace
}  // namespace skylit::baker
