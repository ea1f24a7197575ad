// --error-budget on a box over a ground plane: a generous budget takes the cheapest dome, a
// tight one a denser dome, an impossible one fails naming the best it got; with the corners
// basis every bake (the reference too) is a corners bake and one-sample candidates are skipped.
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "../support/box_site.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/base/error.hpp"
#include "skylit/baker/error_budget.hpp"

namespace skylit::baker {
namespace {

namespace fs = std::filesystem;

class ErrorBudget : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new skylit::test::TempDir("skylit-budget-");
    skylit::test::write_box_site(dir_->path(), "dome:\n  frequency: 2\n"
                                        "planes:\n"
                                        "  - name: ground\n    origin: [-6, -6, 0.01]\n    u: [12, 0, 0]\n"
                                        "    v: [0, 12, 0]\n    resolution: [24, 24]\n"
                                        "  - name: north_wall\n    origin: [1, 1.01, 0]\n    u: [-2, 0, 0]\n"
                                        "    v: [0, 0, 2]\n    resolution: [8, 8]\n");
    quiet_ = std::fopen("/dev/null", "w");
  }
  static void TearDownTestSuite() {
    delete dir_;
    std::fclose(quiet_);
  }

  static BakeOptions bake_options(const std::string& out) {
    BakeOptions o;
    o.site_file = *dir_ / "site.yaml";
    o.out_dir = *dir_ / out;
    o.method = "raytrace";
    o.previews = false;
    o.threads = 2;
    return o;
  }
  // Small candidates and reference so that the suite stays fast on two cores.
  static ErrorBudgetOptions budget_options(double budget) {
    ErrorBudgetOptions o;
    o.budget = budget;
    o.latitude_deg = 35.0;
    o.frequencies = {2, 4};
    o.samples = {1, 4};
    o.reference_frequency = 6;
    o.reference_samples = 16;
    o.scratch_dir = *dir_ / "scratch";
    return o;
  }

  // RMS of the cheapest candidate (ν=2, 1 sample): from the generous run when it ran in this
  // process, else from a run of its own (each test may run alone, as ctest runs them).
  static double cheapest_rms() {
    if (cheapest_rms_ < 0.0) {
      const ErrorBudgetReport report = run_error_budget_bake(bake_options("probe"), budget_options(0.5), quiet_);
      if (report.picked) cheapest_rms_ = report.tried[*report.picked].rms;
    }
    return cheapest_rms_;
  }

  static skylit::test::TempDir* dir_;
  static std::FILE* quiet_;
  static double cheapest_rms_;  // of ν=2, 1 sample
};

skylit::test::TempDir* ErrorBudget::dir_ = nullptr;
std::FILE* ErrorBudget::quiet_ = nullptr;
double ErrorBudget::cheapest_rms_ = -1.0;

TEST_F(ErrorBudget, CandidatesGoCheapestFirstFewerLayersOnATie) {
  ErrorBudgetOptions o;
  const std::vector<CandidateResult> c = budget_candidates(o);
  ASSERT_EQ(c.size(), 9u);
  EXPECT_EQ(c[0].frequency, 2);
  EXPECT_EQ(c[0].samples, 1);
  for (std::size_t i = 1; i < c.size(); ++i) {
    EXPECT_LE(c[i - 1].cost(), c[i].cost());
    if (c[i - 1].cost() == c[i].cost()) {
      EXPECT_LT(c[i - 1].layers, c[i].layers);
    }
  }
  // ν=2 × 4 samples and ν=4 × 1 sample cost alike: the 40-layer dome comes first.
  EXPECT_EQ(c[1].frequency, 2);
  EXPECT_EQ(c[1].samples, 4);
}

TEST_F(ErrorBudget, GenerousBudgetTakesTheCheapestDome) {
  const BakeOptions bake = bake_options("generous");
  const ErrorBudgetReport report = run_error_budget_bake(bake, budget_options(0.5), quiet_);
  ASSERT_TRUE(report.picked.has_value());
  ASSERT_EQ(report.tried.size(), 1u);
  const CandidateResult& picked = report.tried[*report.picked];
  EXPECT_EQ(picked.frequency, 2);
  EXPECT_EQ(picked.samples, 1);
  EXPECT_GT(picked.rms, 0.0);
  EXPECT_LE(picked.rms, 0.5);
  EXPECT_GE(picked.max_abs, picked.rms);
  EXPECT_NE(report.verdict.find("picked ν=2, samples=1"), std::string::npos) << report.verdict;
  EXPECT_GE(report.skies.size(), 10u);  // clear skies across the year at 35°N plus overcast
  cheapest_rms_ = picked.rms;

  const bake_format::VerifyReport verified = bake_format::verify(bake.out_dir);
  ASSERT_TRUE(verified.ok);
  EXPECT_EQ(verified.manifest.plan.frequency, 2);
  EXPECT_EQ(verified.manifest.plan.samples, 1);
  EXPECT_FALSE(fs::exists(*dir_ / "scratch"));
}

TEST_F(ErrorBudget, TightBudgetTakesADenserDome) {
  const double cheapest = cheapest_rms();
  ASSERT_GT(cheapest, 0.0);
  const BakeOptions bake = bake_options("tight");
  const ErrorBudgetReport report = run_error_budget_bake(bake, budget_options(0.6 * cheapest), quiet_);
  ASSERT_TRUE(report.picked.has_value());
  ASSERT_GE(report.tried.size(), 2u);
  const CandidateResult& picked = report.tried[*report.picked];
  EXPECT_GT(picked.cost(), report.tried[0].cost());
  EXPECT_LE(picked.rms, 0.6 * cheapest);
  for (std::size_t i = 0; i < *report.picked; ++i) {
    EXPECT_FALSE(report.tried[i].within_budget);
  }
  EXPECT_NE(report.verdict.find("would not do"), std::string::npos) << report.verdict;
  const bake_format::Manifest manifest = bake_format::read_manifest(bake.out_dir);
  EXPECT_EQ(manifest.plan.frequency, picked.frequency);
  EXPECT_EQ(manifest.plan.samples, picked.samples);
}

TEST_F(ErrorBudget, ImpossibleBudgetFailsNamingTheBest) {
  const BakeOptions bake = bake_options("impossible");
  try {
    run_error_budget_bake(bake, budget_options(1e-9), quiet_);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("no candidate meets"), std::string::npos) << message;
    EXPECT_NE(message.find("the best, ν="), std::string::npos) << message;
  }
  EXPECT_FALSE(fs::exists(bake.out_dir));
  EXPECT_FALSE(fs::exists(*dir_ / "scratch"));
}

TEST_F(ErrorBudget, RefusesWhatItCannotDo) {
  BakeOptions bake = bake_options("refused");
  EXPECT_THROW(run_error_budget_bake(bake, budget_options(0.0), quiet_), InputError);
  EXPECT_THROW(run_error_budget_bake(bake, budget_options(-1.0), quiet_), InputError);
  ErrorBudgetOptions bad_latitude = budget_options(0.1);
  bad_latitude.latitude_deg = 91.0;
  EXPECT_THROW(run_error_budget_bake(bake, bad_latitude, quiet_), InputError);
  bake.frequency = 4;
  EXPECT_THROW(run_error_budget_bake(bake, budget_options(0.1), quiet_), InputError);
  bake.frequency.reset();
  // The corners basis needs min_samples_per_face (3) per face: of the reference, and of some candidate.
  bake.basis = geom::DomeBasis::Corners;
  ErrorBudgetOptions thin_reference = budget_options(0.1);
  thin_reference.reference_samples = min_samples_per_face(geom::DomeBasis::Corners) - 1;
  EXPECT_THROW(run_error_budget_bake(bake, thin_reference, quiet_), InputError);
  bake.basis.reset();
  // … also when the basis comes from the site's dome.basis: only one-sample candidates is refused.
  const fs::path corners_site = *dir_ / "corners_site";
  fs::create_directories(corners_site);
  skylit::test::write_box_site(corners_site, "dome:\n  frequency: 2\n  basis: corners\n"
                                             "planes:\n"
                                             "  - name: ground\n    origin: [-6, -6, 0.01]\n    u: [12, 0, 0]\n"
                                             "    v: [0, 12, 0]\n    resolution: [8, 8]\n");
  BakeOptions from_site = bake_options("refused_site");
  from_site.site_file = corners_site / "site.yaml";
  ErrorBudgetOptions one_sample = budget_options(0.1);
  one_sample.samples = {1};
  try {
    run_error_budget_bake(from_site, one_sample, quiet_);
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("corners basis"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(from_site.out_dir));
  fs::create_directories(bake.out_dir);
  std::ofstream(bake.out_dir / "keep.txt") << "something of the user's";
  EXPECT_THROW(run_error_budget_bake(bake, budget_options(0.1), quiet_), InputError);
  EXPECT_TRUE(fs::exists(bake.out_dir / "keep.txt"));
}

// --basis corners: the candidates and the reference are corners bakes, blended with corner
// luminance; one-sample candidates are skipped and said to be.
TEST_F(ErrorBudget, CornersBasisBakesAndMeasuresCorners) {
  BakeOptions bake = bake_options("corners");
  bake.basis = geom::DomeBasis::Corners;
  const double budget = 0.5;
  std::string log_text;
  ErrorBudgetReport report;
  {
    char* buffer = nullptr;
    std::size_t size = 0;
    std::FILE* log = open_memstream(&buffer, &size);
    ASSERT_NE(log, nullptr);
    report = run_error_budget_bake(bake, budget_options(budget), log);
    std::fclose(log);
    log_text.assign(buffer, size);
    std::free(buffer);
  }
  EXPECT_EQ(report.basis, geom::DomeBasis::Corners);
  EXPECT_EQ(report.reference_basis, geom::DomeBasis::Corners);  // from the reference bake's manifest
  EXPECT_EQ(report.reference_frequency, 6);

  // ν ∈ {2, 4} × samples ∈ {1, 4}: the one-sample candidates are skipped.
  ASSERT_EQ(report.skipped.size(), 2u);
  for (const CandidateResult& c : report.skipped) EXPECT_LT(c.samples, min_samples_per_face(geom::DomeBasis::Corners));
  ASSERT_TRUE(report.picked.has_value());
  for (const CandidateResult& c : report.tried) EXPECT_GE(c.samples, min_samples_per_face(geom::DomeBasis::Corners));
  const CandidateResult& picked = report.tried[*report.picked];
  EXPECT_EQ(picked.frequency, 2);
  EXPECT_EQ(picked.samples, 4);
  EXPECT_EQ(picked.faces, 40);
  EXPECT_EQ(picked.layers, 3 * 40);
  EXPECT_GT(picked.rms, 0.0);
  EXPECT_LE(picked.rms, budget);
  EXPECT_TRUE(picked.within_budget);
  EXPECT_NE(report.verdict.find("corners basis"), std::string::npos) << report.verdict;
  EXPECT_NE(report.verdict.find("skipped"), std::string::npos) << report.verdict;
  EXPECT_NE(log_text.find("reference ν=6, 16 samples, corners basis"), std::string::npos) << log_text;
  EXPECT_NE(log_text.find("needs at least 3 samples per face"), std::string::npos) << log_text;

  const bake_format::VerifyReport verified = bake_format::verify(bake.out_dir);
  ASSERT_TRUE(verified.ok);
  EXPECT_EQ(verified.manifest.plan.basis, geom::DomeBasis::Corners);
  EXPECT_EQ(verified.manifest.plan.frequency, 2);
  EXPECT_EQ(verified.manifest.plan.samples, 4);
  EXPECT_EQ(verified.manifest.layer_count(), 120u);
  EXPECT_FALSE(fs::exists(*dir_ / "scratch"));
}

TEST_F(ErrorBudget, CandidateLayersCountTheBasisLayers) {
  ErrorBudgetOptions o;
  const std::vector<CandidateResult> faces = budget_candidates(o, geom::DomeBasis::Faces);
  const std::vector<CandidateResult> corners = budget_candidates(o, geom::DomeBasis::Corners);
  ASSERT_EQ(faces.size(), corners.size());
  for (std::size_t i = 0; i < faces.size(); ++i) {
    EXPECT_EQ(corners[i].frequency, faces[i].frequency);
    EXPECT_EQ(corners[i].samples, faces[i].samples);
    EXPECT_EQ(corners[i].faces, faces[i].faces);
    EXPECT_EQ(corners[i].layers, geom::layers_per_face(geom::DomeBasis::Corners) * faces[i].layers);
  }
  EXPECT_EQ(min_samples_per_face(geom::DomeBasis::Faces), 1);
  EXPECT_EQ(min_samples_per_face(geom::DomeBasis::Corners), 3);
}

}  // namespace
}  // namespace skylit::baker
