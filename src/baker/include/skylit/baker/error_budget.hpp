#pragma once
// `skylit-bake --error-budget E`: the cheapest dome (frequency ν and samples per face) whose
// shadow ratios stay within E of a denser reference bake over a set of test skies, then the
// final bake with it (docs/baker.md, "Choosing the dome: --error-budget").
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "skylit/baker/bake_job.hpp"
#include "skylit/geom/dome_basis.hpp"

namespace skylit::baker {

// Test skies: analytic clear skies (sky/sky_model.hpp, Preetham scaled to ESRA levels) at 8, 10,
// 12, 14 and 16 h solar time on the March equinox and both solstices at the given latitude
// (those with the sun above the horizon), plus one CIE overcast sky. Every bake, the reference
// included, uses the basis the bake asks for (BakeOptions::basis, else the site's dome.basis).
// For each sky and dome the luminance parameters S (one per layer: S_i for faces, S_{i,k} for
// corners) come as on the live path: an ideal zenith fisheye's frame of the sky (the disc left
// out) through a sky table of that basis (sky::build_sky_table, compute_luminance,
// layer_radiances). The solar disc is a separate sun term whose visibility is ray-cast over the
// disc (area_light_visibility), the same for every bake, so the comparison measures the dome
// alone.
struct ErrorBudgetOptions {
  double budget = 0.01;                   // E: the largest RMS |T − T_ref| accepted
  double latitude_deg = 35.0;             // where the test skies' sun is (the site file has no place)
  double turbidity = 3.0;                 // of the clear test skies
  std::vector<int> frequencies{2, 4, 8};  // candidate dome frequencies
  std::vector<int> samples{1, 4, 16};     // candidate samples per face
  // The reference: 0 = the next even frequency above the largest candidate.
  int reference_frequency = 0;
  int reference_samples = 16;
  // Where the candidate bakes go (removed afterwards); empty = a hidden folder beside out_dir.
  std::filesystem::path scratch_dir;
};

struct CandidateResult {
  int frequency = 0;
  int samples = 0;
  int faces = 0;                // dome faces (10ν²)
  int layers = 0;               // faces × geom::layers_per_face(basis)
  double rms = 0;               // RMS |T − T_ref| over every plane, texel, channel and sky
  double max_abs = 0;           // the largest |T − T_ref|
  double bake_seconds = 0;
  bool within_budget = false;   // rms ≤ budget
  long cost() const { return static_cast<long>(layers) * samples; }
};

struct ErrorBudgetReport {
  double budget = 0;
  geom::DomeBasis basis = geom::DomeBasis::Faces;            // of the candidates (and the picked bake)
  geom::DomeBasis reference_basis = geom::DomeBasis::Faces;  // read from the reference bake's manifest
  int reference_frequency = 0;
  int reference_samples = 0;
  double reference_seconds = 0;
  std::vector<std::string> skies;        // the test skies, by name
  std::vector<CandidateResult> tried;    // cheapest first; stops at the first within budget
  // Candidates not baked: fewer samples per face than the basis needs (min_samples_per_face,
  // bake_job.hpp: min_samples_per_face); cheapest first.
  std::vector<CandidateResult> skipped;
  std::optional<std::size_t> picked;     // into `tried`
  std::string verdict;                   // "picked ν=…, samples=… (B basis): RMS … ≤ E (…); …"
  BakeSummary final_bake;
};

// The candidates in the order they are tried: cost (layers × samples) ascending, fewer layers
// first on a tie (layers are what the live blend pays for; samples only the bake). Layers count
// the basis' layers per face. Candidates with too few samples for the basis are included; the
// run skips them.
std::vector<CandidateResult> budget_candidates(const ErrorBudgetOptions& options,
                                               geom::DomeBasis basis = geom::DomeBasis::Faces);

// Bakes the reference and the candidates (cheapest first) into a scratch folder, picks the
// first within budget, moves its bake to bake.out_dir (with previews and the PCA form when
// `bake` asks for them) and removes the scratch folder. The basis is `bake.basis`, else the
// site's dome.basis; candidates with fewer samples than it needs (min_samples_per_face) are
// skipped (and listed).
// `bake.frequency`, `bake.shard` and `bake.resume` must be unset. InputError for those, for a
// budget that is not a positive number, for a latitude outside [−90, 90], for a reference or
// every candidate with too few samples for the basis, for an output directory that holds
// something without `bake.force`, and when no candidate meets the budget (naming the best one).
// The table and the verdict go to `log` (null: nowhere), progress too.
ErrorBudgetReport run_error_budget_bake(const BakeOptions& bake, const ErrorBudgetOptions& options,
                                        std::FILE* log = stderr);

}  // namespace skylit::baker
