#pragma once
// skylit-bench trade: the trade table of the sky stage over a grid of settings, each measured
// against the dense reference (docs/trade.md).
#include <string>
#include <vector>

#include "skylit/render/building_irradiance.hpp"

namespace skylit::study {

// The grid and the run's settings (skylit-bench trade's options).
struct TradeOptions {
  std::string site_file = "config/sample_site.yaml";
  std::string sky_calib = "config/sky_camera.yaml";
  std::string hmd_calib = "config/hmd_camera.yaml";
  std::string skies_dir = "data/hdri";
  std::vector<std::string> skies;       // stems; empty: every .exr
  std::string out_dir = "build/trade";
  std::vector<int> frequencies{2, 4};
  std::vector<std::string> bases{"faces", "corners"};
  std::vector<int> samples{4, 16};
  std::vector<int> texel_scales{8};
  // skylit-bake --refine per bake: 0, the model as it is; TOL, split where the light changes.
  std::vector<double> refines{0.0};
  // skylit-bake --vertex-fit per bake: 0, each vertex's own light; N, fitted to N² points a triangle.
  std::vector<int> vertex_fits{0};
  // skylit-bake --light-map per bake: 0, none; TEXEL, a light map over the flat regions of at
  // least light_map_min_area m², light_map_min_across texels across a narrow one.
  std::vector<double> light_maps{0.0};
  double light_map_min_area = 0.1;
  int light_map_min_across = 10;
  int light_map_components = 0;  // K: every light map also in its PCA form, which the frame and the error use; 0: none
  // How the compositor holds the light map's values (render.light_map_precision), in the error,
  // the frame and the service alike.
  render::LightMapPrecision light_map_precision = render::LightMapPrecision::Float;
  std::vector<std::string> forms{"full", "lean", "pca8"};
  std::vector<int> bits{16, 8};
  std::vector<std::string> sun{"on", "off"};
  // Separated sources at most with the sun on (sky.max_sources): 1, the sun alone; N, the sun and
  // lamps, each its own term (a ray-cast visibility per source in the blend, a shadow map per
  // source and the lamps per vertex in the frame).
  std::vector<int> sources{1};
  // The building's error (study/building_light.hpp) against a reference with a lambertian ground
  // of this albedo (0: none), with the bake's ground layer lighting the estimate and without it.
  double ground_albedo = 0.2;
  std::vector<double> skip_thresholds{0.0, 0.005};
  std::vector<double> change_thresholds{0.002};
  std::vector<double> smoothings{0.0};
  std::vector<double> render_scales{1.0};
  int frame_width = 640, frame_height = 480;
  int blend_repeats = 9, frame_repeats = 30;
  int supersample = 2, reference_supersample = 4;
  int threads = 2;
  int timing_scale = 1;
  // The whole-frame time the plot and the Pareto front use: "cpu", the process CPU time per frame
  // (compositor + blend) over `cores` (the wall time on an idle machine whose cores share the work
  // evenly; it does not change with other processes' load), or "wall", as measured.
  std::string clock = "cpu";
  int cores = 2;   // blend timing and GPU memory at the site's resolution divided by this
  // Seconds between sky changes: the service blends once per new sky (on the sky thread), not
  // per frame, so the blend's CPU time is spread over the frames between; 0 counts it in every
  // frame (the worst frame: the one whose sky changed, on one thread).
  double sky_interval = 0.0;
  bool quick = false;
  // > 0: each setting's frame rate also from the live service itself (skylit-live, `live_program`),
  // run this many seconds of a 60 Hz camera on the setting's bake with the sky changing every
  // sky_interval seconds (1 when 0): camera in, composite out (docs/trade.md, "The service's own
  // frame rate").
  double live_seconds = 0;
  std::string live_program = "skylit-live";
  // The sky sequence (--sequence): measures the change threshold and the smoothing.
  bool sequence = false;
  int sequence_frames = 60;
  std::string sequence_start = "2026-11-23T05:00:00Z";
  double sequence_lat = 34.68, sequence_lon = 135.84;
  double sequence_cloud = 0.65;
  int sequence_equirect = 128;
};

// skylit-bench trade: the trade table of the sky stage (issue 6). Sweeps a grid of settings — the
// bake's (dome frequency ν, basis faces/corners, samples per face, plane resolution), the stored
// form (full, lean, cropped, PCA with K components; 16- or 8-bit layers) and the live service's (sun
// separation, S threshold = blend.skip_threshold, ΔS threshold = blend.change_threshold,
// smoothing) — over the sample site and real equirect skies, and reports per setting:
//
//   error of T against the dense reference (study::dense_reference): RMS, p99, max of |T − T_ref|
//     over every texel, plane and channel of every sky; for sunny skies (a sun in the equirect),
//     the shadow-edge displacement (docs/trade.md: the mean distance between the 0.5 level lines
//     of T and T_ref, metres on the plane, and the visual angle it subtends from the benchmark
//     visitor 18 m away, degrees);
//   bake time, bake size on disk, GPU memory (the layer textures as the GPU blend holds them:
//     four layers per RGBA slice, 2 or 1 byte per value);
//   per-frame blend time (the live CPU blend, every plane at --timing-scale, median of
//     --blend-repeats) and whole-frame time (the compositor at 640×480 on the headless GL
//     context, draw + glFinish, median of --frame-repeats, plus the blend: a frame with a new
//     sky), wall and process CPU time; the plot and the front use --clock (cpu: CPU time over
//     --cores, which other processes' load does not change; wall).
//
// With --sequence, also a sky sequence (an analytic clear sky over time with a passing cloud, one
// sky per second, a dense reference per frame: study::sequence_reference) run through the live
// path per setting — smoother (τ) → blend weights → CpuBlender with the change threshold, kept
// from frame to frame — for the error the ΔS threshold and the smoothing add and the share of
// frames that re-blend (docs/trade.md, "The sky sequence").
//
// Writes OUT/trade.json, OUT/trade.md and OUT/trade.svg (RMS against whole-frame time, the
// Pareto front marked). Bakes are cached in OUT/bakes (a bake is reused when its folder holds a
int run_trade(TradeOptions o);

}  // namespace skylit::study
