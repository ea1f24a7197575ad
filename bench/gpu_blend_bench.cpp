// The GPU blend alone (blend/gpu_blend.hpp): ν = 2, 4, 8 (40, 160, 640 layers) and 1, 4, 16
// planes of 512², R16F and R8 basis storage (and EAC R11 on request), against the memory-bandwidth floor measured in the
// same run on the same device (the basis bytes read once, at the device's copy bandwidth).
// Prints markdown tables; see bench/RESULTS.md ("GPU blend").
//
//   gpu_blend_bench [--size 512] [--repeats 9] [--batch 20] [--frequencies 2,4,8] [--planes 1,4,16]
//                   [--storage r16f,r8,eac] [--layout packed,single] [--no-check] [--shader-dir DIR]
//                   [--pca K] [--pca-tiles 0,64] [--cropped F]
//
// Layouts: packed = four layers per texel (RGBA16F / RGBA8 arrays; two in RG11 EAC), single = one
// (R16F / R8 / R11 EAC).
// Per configuration: every plane blended once per call (all layers active, no savings), wall
// time to glFinish and, where the driver has GL_EXT_disjoint_timer_query, GPU time; medians of
// --repeats calls after a second of warm-up calls. "Sustained" times --batch calls issued back to back
// (as a frame loop does) and divides by --batch; medians of --repeats such batches. The check table compares each storage's T (RGBA32F
// output) with blend_cpu on one plane. Builds without CMake: bench/gpu_standalone.sh.
//
// --pca K (default 0: off) adds the table "PCA forms": per ν and plane count, the full basis
// (RGBA16F packed, as above) beside its PCA form (BasisImages::projection) with K + 1 stored layers,
// untiled (tile 0 in --pca-tiles) and tiled (clustered PCA, BasisImages::tile = T for each T > 0 in
// --pca-tiles). Synthetic PCA form: K + 1 half layers, the mean in [0.3, 0.7] and K eigen-images in
// [-1, 1]; projection n × (tile_count · (K + 1)), column t · (K + 1) = A_l (tile t's mean) and
// A_l · [-0.1, 0.1] elsewhere, so that T stays near [0, 1]. Half storage, packed layout only (the
// eigen-images are negative). The check table adds each PCA form against blend_cpu.
//
// --cropped F (default 0: off; 0 < F <= 1) adds the table "Cropped forms": per ν, storage, layout
// and plane count, the whole-layer basis above beside its cropped form (BasisImages::crops, held
// by the GPU blend in an atlas of 16 × 16 pages): each layer kept within a square of F of the
// plane's texels (side round(√F · size)) at a pseudo-random place, B = A outside it
// (bench/synthetic_pca.hpp, synthetic_cropped_basis, as blend_bench's, with each fill rounded to
// half as a baked cropped form's; 0.43 is what the sample site's ground keeps at ν = 8). Basis read (GpuBlender::basis_bytes(): the atlas, unused page
// slots included), pages, time, floor and time / floor as in the first table, and time / the
// whole-layer basis's. The check table adds each cropped form against blend_cpu.
#include <EGL/egl.h>
#include <GLES3/gl31.h>
#include <GLES2/gl2ext.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "skylit/gpu/egl_context.hpp"
#include "skylit/gpu/gl.hpp"
#include "skylit/gpu/shader.hpp"
#include "synthetic_pca.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/blend/gpu_blend.hpp"

namespace {

using skylit::blend::BasisImages;
using skylit::blend::BasisStorage;
using skylit::blend::BlendWeights;
using skylit::blend::GpuBlender;
using skylit::blend::GpuBlendOptions;
using skylit::blend::ShadowRatioFormat;
using Clock = std::chrono::steady_clock;

struct Settings {
  int size = 512;
  int repeats = 9;
  int batch = 20;  // calls per sample of the sustained rate
  std::vector<int> frequencies{2, 4, 8};
  std::vector<int> planes{1, 4, 16};
  std::vector<BasisStorage> storages{BasisStorage::Half, BasisStorage::Unorm8};
  std::vector<bool> packed{true, false};
  bool check = true;
  std::string shader_dir;
  int pca = 0;                       // K eigen-images of the PCA forms; 0: no PCA table
  std::vector<int> pca_tiles{0, 64};  // 0: untiled
  double cropped = 0.0;              // F: share of the texels each cropped layer keeps; 0: no cropped table
};

[[noreturn]] void usage(const std::string& problem) {
  std::fprintf(stderr,
               "gpu_blend_bench: %s\nusage: gpu_blend_bench [--size N] [--repeats N] [--batch N] [--frequencies 2,4,8] "
               "[--planes 1,4,16] [--storage r16f,r8,eac] [--layout packed,single] [--no-check] [--shader-dir DIR] "
               "[--pca K] [--pca-tiles 0,64] [--cropped F]\n",
               problem.c_str());
  std::exit(2);
}

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream stream(text);
  std::string part;
  while (std::getline(stream, part, ',')) parts.push_back(part);
  return parts;
}

int positive(const std::string& text, const std::string& option) {
  try {
    std::size_t used = 0;
    const int value = std::stoi(text, &used);
    if (used == text.size() && value > 0) return value;
  } catch (const std::exception&) {
  }
  usage("option " + option + " needs positive integers, got '" + text + "'");
}

int non_negative(const std::string& text, const std::string& option) {
  try {
    std::size_t used = 0;
    const int value = std::stoi(text, &used);
    if (used == text.size() && value >= 0) return value;
  } catch (const std::exception&) {
  }
  usage("option " + option + " needs integers >= 0, got '" + text + "'");
}

double share(const std::string& text, const std::string& option) {
  try {
    std::size_t used = 0;
    const double value = std::stod(text, &used);
    if (used == text.size() && value > 0.0 && value <= 1.0) return value;
  } catch (const std::exception&) {
  }
  usage("option " + option + " needs a number in (0, 1], got '" + text + "'");
}

Settings parse(int argc, char** argv) {
  Settings s;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage("option " + arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--size") {
      s.size = positive(value(), arg);
    } else if (arg == "--repeats") {
      s.repeats = positive(value(), arg);
    } else if (arg == "--batch") {
      s.batch = positive(value(), arg);
    } else if (arg == "--frequencies") {
      s.frequencies.clear();
      for (const std::string& f : split(value())) s.frequencies.push_back(positive(f, arg));
    } else if (arg == "--planes") {
      s.planes.clear();
      for (const std::string& p : split(value())) s.planes.push_back(positive(p, arg));
    } else if (arg == "--storage") {
      s.storages.clear();
      for (const std::string& name : split(value())) {
        if (name == "r16f") {
          s.storages.push_back(BasisStorage::Half);
        } else if (name == "r8") {
          s.storages.push_back(BasisStorage::Unorm8);
        } else if (name == "eac") {
          // Not in the default list: the synthetic layers are noise, EAC's worst case, and every
          // plane encodes its own (about 0.4 s of one core per 512² layer).
          s.storages.push_back(BasisStorage::Eac11);
        } else {
          usage("--storage takes r16f, r8 and/or eac, got '" + name + "'");
        }
      }
    } else if (arg == "--layout") {
      s.packed.clear();
      for (const std::string& name : split(value())) {
        if (name != "packed" && name != "single") usage("--layout takes packed and/or single, got '" + name + "'");
        s.packed.push_back(name == "packed");
      }
    } else if (arg == "--no-check") {
      s.check = false;
    } else if (arg == "--shader-dir") {
      s.shader_dir = value();
    } else if (arg == "--pca") {
      s.pca = non_negative(value(), arg);
    } else if (arg == "--pca-tiles") {
      s.pca_tiles.clear();
      for (const std::string& t : split(value())) s.pca_tiles.push_back(non_negative(t, arg));
    } else if (arg == "--cropped") {
      s.cropped = share(value(), arg);
    } else {
      usage("unknown option '" + arg + "'");
    }
  }
  return s;
}

double median(std::vector<double> values) {
  if (values.empty()) return std::nan("");
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

// GL_EXT_disjoint_timer_query: GPU time of the commands between begin() and end().
class GpuTimer {
 public:
  explicit GpuTimer(const skylit::gpu::HeadlessContext& context) {
    if (!context.has_extension("GL_EXT_disjoint_timer_query")) return;
    get_result_ = reinterpret_cast<PFNGLGETQUERYOBJECTUI64VEXTPROC>(eglGetProcAddress("glGetQueryObjectui64vEXT"));
    if (get_result_ == nullptr) return;
    glGenQueries(1, &query_);
  }
  ~GpuTimer() {
    if (query_ != 0) glDeleteQueries(1, &query_);
  }
  GpuTimer(const GpuTimer&) = delete;
  GpuTimer& operator=(const GpuTimer&) = delete;

  bool available() const { return query_ != 0; }
  void begin() const {
    if (!available()) return;
    GLint disjoint = 0;
    glGetIntegerv(GL_GPU_DISJOINT_EXT, &disjoint);  // clears the flag
    glBeginQuery(GL_TIME_ELAPSED_EXT, query_);
  }
  void end() const {
    if (available()) glEndQuery(GL_TIME_ELAPSED_EXT);
  }
  // Seconds, or nothing when unavailable or when the measurement was disturbed (disjoint).
  std::optional<double> seconds() const {
    if (!available()) return std::nullopt;
    GLuint64 nanoseconds = 0;
    get_result_(query_, GL_QUERY_RESULT, &nanoseconds);
    GLint disjoint = 0;
    glGetIntegerv(GL_GPU_DISJOINT_EXT, &disjoint);
    if (disjoint != 0) return std::nullopt;
    return static_cast<double>(nanoseconds) * 1e-9;
  }

 private:
  GLuint query_ = 0;
  PFNGLGETQUERYOBJECTUI64VEXTPROC get_result_ = nullptr;
};

struct Timing {
  double wall_s = 0;
  std::optional<double> gpu_s;
  double seconds() const { return gpu_s ? *gpu_s : wall_s; }  // GPU time where the driver has a timer
};

// Median wall and GPU time of `work` (per call of `batch` calls issued back to back).
// Warm-up: at least two calls, and `warm_up` of them. A GPU runs a freshly uploaded or long
// idle workload several times slower for a while (seen on an H100: one 640-layer plane took
// 0.51 ms after 150 ms of blending, 0.15 ms after a second), and the service blends every frame.
template <class Work>
Timing time_it(const GpuTimer& timer, int repeats, Work&& work, int batch = 1,
               std::chrono::milliseconds warm_up = std::chrono::milliseconds(1000)) {
  const auto warm_until = Clock::now() + warm_up;
  for (int i = 0; i < 2 || Clock::now() < warm_until; ++i) {
    work();
    glFinish();
  }
  std::vector<double> wall;
  std::vector<double> gpu;
  for (int i = 0; i < repeats; ++i) {
    const auto start = Clock::now();
    timer.begin();
    for (int b = 0; b < batch; ++b) work();
    timer.end();
    glFinish();
    wall.push_back(std::chrono::duration<double>(Clock::now() - start).count() / batch);
    if (const std::optional<double> s = timer.seconds()) gpu.push_back(*s / batch);
  }
  Timing t;
  t.wall_s = median(wall);
  // A timer that reads less than 1 % of the wall time measured nothing (llvmpipe offers the
  // extension but runs the work outside the query): wall time it is.
  if (gpu.size() == wall.size() && median(gpu) >= 0.01 * t.wall_s) t.gpu_s = median(gpu);
  return t;
}

// The device's copy bandwidth: a 256 MiB buffer copied into another, bytes read plus written
// per second, by glCopyBufferSubData and by a compute shader (shaders/bandwidth_copy.comp); the
// floor uses the faster (a driver may give glCopyBufferSubData to a slower copy engine).
struct Bandwidth {
  double copy_bytes_per_s = 0;     // glCopyBufferSubData
  double compute_bytes_per_s = 0;  // bandwidth_copy.comp
  bool from_gpu_timer = false;
  double best() const { return std::max(copy_bytes_per_s, compute_bytes_per_s); }
};

Bandwidth copy_bandwidth(const GpuTimer& timer, int repeats, const std::string& shader_dir) {
  constexpr GLsizeiptr kBytes = GLsizeiptr{256} << 20;
  constexpr GLuint kGroups = 32768;  // × 256 invocations × 2 rows × 16 bytes = 256 MiB
  const skylit::gpu::Buffer source = skylit::gpu::make_buffer();
  const skylit::gpu::Buffer target = skylit::gpu::make_buffer();
  glBindBuffer(GL_COPY_READ_BUFFER, source.get());
  glBufferData(GL_COPY_READ_BUFFER, kBytes, nullptr, GL_STATIC_DRAW);
  glBindBuffer(GL_COPY_WRITE_BUFFER, target.get());
  glBufferData(GL_COPY_WRITE_BUFFER, kBytes, nullptr, GL_STATIC_DRAW);
  // Written once, so that no driver can treat the source as empty.
  glCopyBufferSubData(GL_COPY_WRITE_BUFFER, GL_COPY_READ_BUFFER, 0, 0, kBytes);
  skylit::gpu::check_gl_error("copy bandwidth: buffers");
  const Timing copy = time_it(timer, std::max(repeats, 5),
                              [&] { glCopyBufferSubData(GL_COPY_READ_BUFFER, GL_COPY_WRITE_BUFFER, 0, 0, kBytes); });
  const skylit::gpu::Program program =
      skylit::gpu::load_program(skylit::gpu::find_shader_dir(shader_dir), {"bandwidth_copy.comp"});
  glUseProgram(program.get());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, source.get());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, target.get());
  const Timing compute = time_it(timer, std::max(repeats, 5), [&] {
    glDispatchCompute(kGroups, 2, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  });
  skylit::gpu::check_gl_error("copy bandwidth: copies");
  Bandwidth b;
  b.from_gpu_timer = copy.gpu_s.has_value() && compute.gpu_s.has_value();
  b.copy_bytes_per_s = 2.0 * static_cast<double>(kBytes) / copy.seconds();
  b.compute_bytes_per_s = 2.0 * static_cast<double>(kBytes) / compute.seconds();
  return b;
}

using skylit::bench::Random;

// A plane of `layers` faces of a hemisphere, B = A·f with f = 0 (shadow), 1 (open sky) or
// between; every A > 0, so that every layer is active.
BasisImages synthetic_basis(int size, int layers, std::uint64_t seed) {
  Random random{seed};
  BasisImages basis;
  basis.name = "synthetic";
  basis.width = size;
  basis.height = size;
  basis.layers = layers;
  const double omega = 6.283185307179586 / layers;
  for (int i = 0; i < layers; ++i) basis.unoccluded.push_back(omega * (0.1 + 0.9 * random.next()));
  basis.half.resize(basis.texel_count() * static_cast<std::size_t>(layers));
  for (int i = 0; i < layers; ++i) {
    const double a = basis.unoccluded[static_cast<std::size_t>(i)];
    std::uint16_t* layer = basis.half.data() + static_cast<std::size_t>(i) * basis.texel_count();
    for (std::size_t k = 0; k < basis.texel_count(); ++k) {
      const double pick = random.next();
      const double f = pick < 0.3 ? 0.0 : (pick < 0.6 ? 1.0 : random.next());
      layer[k] = skylit::blend::float_to_half(static_cast<float>(a * f));
    }
  }
  return basis;
}


BlendWeights sky_weights(const BasisImages& basis, std::uint64_t seed) {
  Random random{seed};
  std::vector<Eigen::Vector3d> S;
  for (int i = 0; i < basis.source_layers(); ++i) S.emplace_back(0.2 + random.next(), 0.3 + random.next(), 0.5 + random.next());
  return skylit::blend::blend_weights(basis, S, std::nullopt);
}

const char* storage_name(BasisStorage storage, bool packed) {
  if (storage == BasisStorage::Half) return packed ? "RGBA16F (4 layers/texel)" : "R16F";
  if (storage == BasisStorage::Eac11) return packed ? "RG11 EAC (2 layers/texel)" : "R11 EAC";
  return packed ? "RGBA8 (4 layers/texel)" : "R8";
}

GpuBlendOptions blend_options(BasisStorage storage, bool packed, const Settings& settings) {
  GpuBlendOptions options;
  options.storage = storage;
  options.pack_layers = packed;
  options.shader_dir = settings.shader_dir;
  return options;
}

// One basis of a comparison table (PCA forms, cropped forms) and its timings per plane count.
struct Form {
  std::string name;
  const BasisImages* basis;
  BlendWeights weights;
  std::vector<Timing> per_call;   // per plane count
  std::vector<Timing> sustained;  // per plane count
  std::size_t bytes = 0;          // of one plane's basis texture array (or atlas)
  int slices = 0;
  int pages = 0;
};

// Times `form` blended on every plane count of the run (one blender per plane, all kept until
// the largest count), once per call and sustained, and notes its texture's size.
void time_form(Form& form, const GpuBlendOptions& options, const GpuTimer& timer, const Settings& settings) {
  std::vector<std::unique_ptr<GpuBlender>> blenders;
  for (const int planes : settings.planes) {
    while (static_cast<int>(blenders.size()) < planes) blenders.push_back(std::make_unique<GpuBlender>(*form.basis, options));
    const auto call = [&] {
      for (int j = 0; j < planes; ++j) {
        blenders[static_cast<std::size_t>(j)]->invalidate();
        blenders[static_cast<std::size_t>(j)]->blend(form.weights);
      }
    };
    form.per_call.push_back(time_it(timer, settings.repeats, call));
    form.sustained.push_back(time_it(timer, settings.repeats, call, settings.batch, std::chrono::milliseconds(0)));
    form.bytes = blenders.front()->basis_bytes();
    form.slices = blenders.front()->slices();
    form.pages = blenders.front()->pages();
  }
}

}  // namespace

int main(int argc, char** argv) {
  const Settings settings = parse(argc, argv);
  try {
    const skylit::gpu::HeadlessContext context;
    std::printf("device: %s\n", context.description().c_str());
    const GpuTimer timer(context);
    const Bandwidth bandwidth = copy_bandwidth(timer, settings.repeats, settings.shader_dir);
    std::printf("copy bandwidth (256 MiB buffer, bytes read + written, %s): glCopyBufferSubData %.1f GB/s, "
                "compute shader %.1f GB/s\n",
                bandwidth.from_gpu_timer ? "GPU timer" : "wall time to glFinish", bandwidth.copy_bytes_per_s * 1e-9,
                bandwidth.compute_bytes_per_s * 1e-9);
    std::printf("GPU timer (GL_EXT_disjoint_timer_query): %s\n\n",
                !timer.available() ? "no" : (bandwidth.from_gpu_timer ? "yes" : "offered, but reads no time: wall time used"));

    std::printf("| basis | ν (layers) | planes of %d² | basis read | wall | GPU | sustained | floor | GPU / floor | "
                "sustained / floor |\n",
                settings.size);
    std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
    struct Check {
      std::string basis;
      int frequency;
      double max_difference;
    };
    std::vector<Check> checks;
    // max |T_gpu - T_cpu| over one plane, RGBA32F output.
    const auto compare_with_cpu = [](const BasisImages& basis, const GpuBlendOptions& options, const BlendWeights& weights) {
      GpuBlendOptions exact = options;
      exact.output = ShadowRatioFormat::Float;
      GpuBlender blender(basis, exact);
      blender.blend(weights);
      const std::vector<float> gpu = blender.read_back();
      std::vector<float> cpu(3 * basis.texel_count());
      skylit::blend::blend_cpu(basis, weights, {}, cpu);
      double worst = 0;
      for (std::size_t k = 0; k < cpu.size(); ++k) worst = std::max(worst, std::abs(static_cast<double>(gpu[k]) - cpu[k]));
      return worst;
    };
    std::vector<std::string> pca_rows;      // the "PCA forms" table, printed after the others
    std::vector<std::string> cropped_rows;  // the "Cropped forms" table, printed last
    for (const int frequency : settings.frequencies) {
      const int layers = 10 * frequency * frequency;
      const BasisImages basis = synthetic_basis(settings.size, layers, 0x5EED0000ULL + static_cast<std::uint64_t>(frequency));
      const BlendWeights weights = sky_weights(basis, 17);
      for (const bool packed : settings.packed) {
      for (const BasisStorage storage : settings.storages) {
        const GpuBlendOptions options = blend_options(storage, packed, settings);
        std::vector<std::unique_ptr<GpuBlender>> blenders;
        for (const int planes : settings.planes) {
          while (static_cast<int>(blenders.size()) < planes) blenders.push_back(std::make_unique<GpuBlender>(basis, options));
          const auto call = [&] {
            for (int j = 0; j < planes; ++j) {
              blenders[static_cast<std::size_t>(j)]->invalidate();
              blenders[static_cast<std::size_t>(j)]->blend(weights);
            }
          };
          const Timing t = time_it(timer, settings.repeats, call);
          const Timing sustained = time_it(timer, settings.repeats, call, settings.batch, std::chrono::milliseconds(0));
          const double bytes = static_cast<double>(planes) * static_cast<double>(blenders.front()->basis_bytes());
          const double floor_s = bytes / bandwidth.best();
          const double measured = t.seconds();
          const double measured_sustained = sustained.seconds();
          char gpu_text[32] = "n/a";
          if (t.gpu_s) std::snprintf(gpu_text, sizeof gpu_text, "%.3f ms", *t.gpu_s * 1e3);
          std::printf("| %s | %d (%d) | %d | %.0f MiB | %.3f ms | %s | %.3f ms | %.3f ms | %.2f× | %.2f× |\n",
                      storage_name(storage, packed), frequency, layers, planes, bytes / (1 << 20), t.wall_s * 1e3, gpu_text,
                      measured_sustained * 1e3, floor_s * 1e3, measured / floor_s, measured_sustained / floor_s);
          std::fflush(stdout);
        }
        blenders.clear();
        if (settings.check) checks.push_back({storage_name(storage, packed), frequency, compare_with_cpu(basis, options, weights)});
      }
      }
      if (settings.pca > 0) {
        // The full basis and its PCA forms: untiled, then each tile size > 0 of --pca-tiles. Same
        // seed for each, so that they store the same K + 1 layers and differ in the projection.
        std::vector<int> tiles{0};
        for (const int tile : settings.pca_tiles) {
          if (std::find(tiles.begin(), tiles.end(), tile) == tiles.end()) tiles.push_back(tile);
        }
        std::vector<BasisImages> pca_forms;
        for (const int tile : tiles) {
          pca_forms.push_back(skylit::bench::synthetic_pca_basis(settings.size, basis.unoccluded, settings.pca, tile,
                                                  0xCA5E0000ULL + static_cast<std::uint64_t>(frequency)));
        }
        std::vector<Form> forms;
        forms.push_back({"full", &basis, weights, {}, {}, 0, 0, 0});
        for (const BasisImages& pca : pca_forms) {
          const std::string name = "PCA K=" + std::to_string(settings.pca) +
                                   (pca.tile > 0 ? ", tile " + std::to_string(pca.tile) + " (" +
                                                       std::to_string(pca.tile_count()) + " tiles)"
                                                 : ", untiled");
          forms.push_back({name, &pca, sky_weights(pca, 17), {}, {}, 0, 0, 0});
        }
        const GpuBlendOptions options = blend_options(BasisStorage::Half, true, settings);
        for (Form& form : forms) {
          time_form(form, options, timer, settings);
          if (settings.check && form.basis != &basis) {
            checks.push_back({form.name + " (RGBA16F)", frequency, compare_with_cpu(*form.basis, options, form.weights)});
          }
        }
        for (std::size_t p = 0; p < settings.planes.size(); ++p) {
          const int planes = settings.planes[p];
          const double full = forms.front().per_call[p].seconds();
          const double full_sustained = forms.front().sustained[p].seconds();
          for (const Form& form : forms) {
            const Timing& t = form.per_call[p];
            const double sustained = form.sustained[p].seconds();
            char gpu_text[32] = "n/a";
            if (t.gpu_s) std::snprintf(gpu_text, sizeof gpu_text, "%.3f ms", *t.gpu_s * 1e3);
            char row[512];
            std::snprintf(row, sizeof row, "| %s | %d (%d) | %d (%d slices) | %d | %.1f MiB | %.3f ms | %s | %.3f ms | %.3f× | %.3f× |",
                          form.name.c_str(), frequency, layers, form.basis->layers, form.slices, planes,
                          static_cast<double>(planes) * static_cast<double>(form.bytes) / (1 << 20), t.wall_s * 1e3,
                          gpu_text, sustained * 1e3, t.seconds() / full, sustained / full_sustained);
            pca_rows.emplace_back(row);
            std::fprintf(stderr, "PCA form measured: %s\n", row);  // kept if a time limit ends the run
          }
        }
      }
      if (settings.cropped > 0.0) {
        // The whole-layer basis and its cropped form, in each storage and layout of the run.
        BasisImages cropped = skylit::bench::synthetic_cropped_basis(
            basis, settings.cropped, 0xC0ULL + static_cast<std::uint64_t>(frequency));
        // Each fill A rounded to half, as load_basis's cropped form stores it (blend/basis.cpp) and
        // as the GPU's pages hold it outside a rectangle: unrounded, the check would read the
        // fill's half rounding (~1e-5 of T here) instead of the blend's.
        for (skylit::blend::LayerCrop& crop : cropped.crops) {
          crop.fill = skylit::blend::half_to_float(skylit::blend::float_to_half(crop.fill));
        }
        const int side = cropped.crops.front().cols;
        char cropped_name[96];
        std::snprintf(cropped_name, sizeof cropped_name, "cropped to %.0f%% (%d² of %d²)",
                      100.0 * side * side / (static_cast<double>(settings.size) * settings.size), side, settings.size);
        for (const bool packed : settings.packed) {
        for (const BasisStorage storage : settings.storages) {
          const GpuBlendOptions options = blend_options(storage, packed, settings);
          std::vector<Form> forms;
          forms.push_back({"whole layers", &basis, weights, {}, {}, 0, 0, 0});
          forms.push_back({cropped_name, &cropped, weights, {}, {}, 0, 0, 0});
          for (Form& form : forms) {
            time_form(form, options, timer, settings);
            if (settings.check && form.basis != &basis) {
              checks.push_back({form.name + ", " + storage_name(storage, packed), frequency,
                                compare_with_cpu(*form.basis, options, weights)});
            }
          }
          for (std::size_t p = 0; p < settings.planes.size(); ++p) {
            const int planes = settings.planes[p];
              const double full = forms.front().per_call[p].seconds();
            for (const Form& form : forms) {
              const Timing& t = form.per_call[p];
              const double measured = t.seconds();
              const double sustained = form.sustained[p].seconds();
              const double bytes = static_cast<double>(planes) * static_cast<double>(form.bytes);
              const double floor_s = bytes / bandwidth.best();
              char gpu_text[32] = "n/a";
              if (t.gpu_s) std::snprintf(gpu_text, sizeof gpu_text, "%.3f ms", *t.gpu_s * 1e3);
              char pages_text[48];
              if (form.pages > 0) {
                std::snprintf(pages_text, sizeof pages_text, "%d (%d slices)", form.pages, form.slices);
              } else {
                std::snprintf(pages_text, sizeof pages_text, "— (%d slices)", form.slices);
              }
              char row[640];
              std::snprintf(row, sizeof row,
                            "| %s | %s | %d (%d) | %d | %.2f MiB | %s | %.3f ms | %s | %.3f ms | %.4f ms | %.2f× | %.2f× | "
                            "%.3f× |",
                            form.name.c_str(), storage_name(storage, packed), frequency, layers, planes,
                            bytes / (1 << 20), pages_text, t.wall_s * 1e3, gpu_text, sustained * 1e3, floor_s * 1e3,
                            measured / floor_s, sustained / floor_s, measured / full);
              cropped_rows.emplace_back(row);
              std::fprintf(stderr, "cropped form measured: %s\n", row);
            }
          }
        }
        }
      }
    }
    if (!checks.empty()) {
      std::printf("\nmax |T_gpu - T_cpu| on one plane (RGBA32F output, blend_cpu reference):\n\n");
      std::printf("| basis | ν | max abs difference |\n|---|---|---|\n");
      for (const Check& c : checks) std::printf("| %s | %d | %.3g |\n", c.basis.c_str(), c.frequency, c.max_difference);
    }
    if (!pca_rows.empty()) {
      std::printf("\nPCA forms (RGBA16F, 4 layers/texel; every plane blended once per call, all layers active; "
                  "time = GPU time where the driver has a timer, else wall time; ratios to the full basis):\n\n");
      std::printf("| form | ν (n layers) | stored layers | planes of %d² | basis read | wall | GPU | sustained | "
                  "time / full | sustained / full |\n",
                  settings.size);
      std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
      for (const std::string& row : pca_rows) std::printf("%s\n", row.c_str());
    }
    if (!cropped_rows.empty()) {
      std::printf("\nCropped forms (every plane blended once per call, all layers active; time = GPU time where the "
                  "driver has a timer, else wall time; floor = basis read / the faster copy bandwidth; time / whole = "
                  "time over the whole-layer basis's in the same storage):\n\n");
      std::printf("| form | basis | ν (layers) | planes of %d² | basis read | pages | wall | GPU | sustained | floor | "
                  "GPU / floor | sustained / floor | time / whole |\n",
                  settings.size);
      std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
      for (const std::string& row : cropped_rows) std::printf("%s\n", row.c_str());
    }
    std::printf("\nfloor = basis bytes / the faster copy bandwidth (read + written); time = GPU time where the "
                "driver has a timer, else wall time\n");
  } catch (const std::exception& error) {
    std::fprintf(stderr, "gpu_blend_bench: %s\n", error.what());
    return 1;
  }
  return 0;
}
