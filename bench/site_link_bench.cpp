// The sky link of a site over a real broker (docs/site.md): one sky node publishes retained skies
// at a steady rate to N HMD nodes, each of which decodes every sky and blends one plane of its
// own with it. Latency is the time from the sky node's publish to the end of a node's blend,
// over every (node, sky) pair; everything runs on this machine, the broker on loopback.
//
//   site_link_bench [--nodes 1,4,16,64] [--skies 100] [--rate 10] [--plane-size 64] [--frequency 2]
//                   [--mosquitto /usr/sbin/mosquitto]
//
// Per N a fresh mosquitto (anonymous, no persistence, a free loopback port) serves the run. Each
// node is its own MqttClient (its own connection and network thread) subscribed to
// skylit/bench/sky; its handler decodes the sky against the node's identity and last sequence,
// computes blend_weights and blend_cpu (one thread: the nodes share this machine's cores) of a
// --plane-size² plane of 10ν² faces with a partly shadowed sun, and notes when its blend
// finished. Before the timed skies a retained warm-up sky (sequence 0) must have been blended by
// every node: then every node is connected and subscribed. Printed per N, as a markdown table:
// latency p50, p99 and max, the decode-and-blend time alone (median), the message size, skies
// dropped by a decoder or never blended (missed), and the broker's CPU time over the run (utime
// + stime of its process) in seconds and as a share of the run's wall time.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <numbers>
#include <optional>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/sky_link/mqtt_client.hpp"
#include "skylit/sky_link/sky_message.hpp"

namespace {

namespace fs = std::filesystem;
using skylit::blend::BasisImages;
using skylit::sky_link::DecodedSky;
using skylit::sky_link::MqttClient;
using skylit::sky_link::MqttSettings;
using skylit::sky_link::SkyIdentity;
using skylit::sky_link::SkyMessage;
using Clock = std::chrono::steady_clock;

constexpr const char* kTopic = "skylit/bench/sky";

// xorshift64*: a cheap, seeded source for texel values (tens of millions of them at 64 nodes).
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed * 0x9e3779b97f4a7c15ull + 1) {}
  double next() {  // in [0, 1)
    state_ ^= state_ >> 12;
    state_ ^= state_ << 25;
    state_ ^= state_ >> 27;
    return static_cast<double>((state_ * 0x2545f4914f6cdd1dull) >> 11) * 0x1p-53;
  }

 private:
  std::uint64_t state_;
};

// mosquitto on a free loopback port with a config of its own, in a directory removed at the end.
class Broker {
 public:
  explicit Broker(const std::string& program) {
    if (!fs::exists(program)) throw std::runtime_error(program + " is missing: install Debian's mosquitto");
    std::string pattern = (fs::temp_directory_path() / "site_link_bench_XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("no temporary directory for mosquitto");
    dir_ = pattern;
    port_ = free_port();
    const fs::path config = dir_ / "mosquitto.conf";
    std::ofstream(config) << "listener " << port_ << " 127.0.0.1\nallow_anonymous true\npersistence false\n";
    const std::string log = (dir_ / "mosquitto.log").string();
    pid_ = ::fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      FILE* out = std::freopen(log.c_str(), "a", stderr);
      (void)out;
      ::execl(program.c_str(), program.c_str(), "-c", config.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    while (!accepts()) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("mosquitto ended at start; its log: " + log);
      }
      if (Clock::now() > deadline) {
        stop();
        throw std::runtime_error("mosquitto did not open port " + std::to_string(port_));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  ~Broker() {
    stop();
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  Broker(const Broker&) = delete;
  Broker& operator=(const Broker&) = delete;

  int port() const { return port_; }

  // The broker's CPU time so far, user and system: fields 14 and 15 of /proc/PID/stat, counted
  // after the command name, which may hold spaces and ends at the last ')'.
  double cpu_seconds() const {
    std::ifstream in("/proc/" + std::to_string(pid_) + "/stat");
    std::string stat;
    std::getline(in, stat);  // one line
    const std::size_t name_end = stat.rfind(')');
    if (name_end == std::string::npos) throw std::runtime_error("cannot read /proc/" + std::to_string(pid_) + "/stat");
    std::istringstream fields(stat.substr(name_end + 1));
    std::string skipped;
    for (int field = 3; field <= 13; ++field) fields >> skipped;
    unsigned long long user = 0, system = 0;
    fields >> user >> system;
    return static_cast<double>(user + system) / static_cast<double>(::sysconf(_SC_CLK_TCK));
  }

 private:
  static sockaddr_in loopback(int port) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    return address;
  }
  static int free_port() {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address = loopback(0);
    socklen_t size = sizeof address;
    const bool ok = fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0 &&
                    ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size) == 0;
    if (fd >= 0) ::close(fd);
    if (!ok) throw std::runtime_error("no free loopback port");
    return ntohs(address.sin_port);
  }
  bool accepts() const {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    const sockaddr_in address = loopback(port_);
    const bool ok = fd >= 0 && ::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0;
    if (fd >= 0) ::close(fd);
    return ok;
  }

  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }

  fs::path dir_;
  int port_ = 0;
  pid_t pid_ = -1;
};

struct Settings {
  std::vector<int> nodes{1, 4, 16, 64};
  int skies = 100;
  double rate = 10;
  int plane_size = 64;
  int frequency = 2;
  std::string mosquitto = "/usr/sbin/mosquitto";
};

SkyIdentity bench_identity(const Settings& settings) {
  return {"bench site", settings.frequency, skylit::geom::DomeBasis::Faces, 10 * settings.frequency * settings.frequency};
}

// A plane over horizontal ground that sees every face: B = A·f with f in [0, 1], as half floats,
// and a sun shadowed on 30% of its texels.
struct Plane {
  BasisImages basis;
  std::vector<float> visibility;
};

Plane make_plane(int side, int layers, std::uint64_t seed) {
  Random random(seed);
  Plane plane;
  BasisImages& basis = plane.basis;
  basis.name = "plane";
  basis.width = side;
  basis.height = side;
  basis.layers = layers;
  const double omega = 2.0 * std::numbers::pi / layers;
  for (int i = 0; i < layers; ++i) basis.unoccluded.push_back(omega * (0.2 + 0.8 * random.next()));
  basis.half.resize(basis.texel_count() * static_cast<std::size_t>(layers));
  for (int i = 0; i < layers; ++i) {
    const double a = basis.unoccluded[static_cast<std::size_t>(i)];
    std::uint16_t* layer = basis.half.data() + static_cast<std::size_t>(i) * basis.texel_count();
    for (std::size_t t = 0; t < basis.texel_count(); ++t) {
      layer[t] = skylit::blend::float_to_half(static_cast<float>(a * std::min(1.0, 1.3 * random.next())));
    }
  }
  plane.visibility.resize(basis.texel_count());
  for (float& v : plane.visibility) v = random.next() < 0.3 ? 0.0f : 1.0f;
  return plane;
}

// Sky `sequence` as the sky node would publish it: S drifting slowly as clouds pass, the sun
// moving along its arc.
SkyMessage make_sky(const SkyIdentity& identity, std::uint64_t sequence, double rate) {
  SkyMessage m;
  m.identity = identity;
  m.sequence = sequence;
  m.frame_timestamp = static_cast<double>(sequence) / rate;
  m.utc = 1782000000 + static_cast<std::int64_t>(m.frame_timestamp);
  Random random(7);
  const double drift = 1.0 + 0.2 * std::sin(0.1 * static_cast<double>(sequence));
  for (int i = 0; i < identity.layers; ++i) {
    m.S.emplace_back(drift * (0.5 + random.next()), drift * (0.5 + random.next()), drift * (0.5 + random.next()));
  }
  const double azimuth = 0.01 * static_cast<double>(sequence);
  skylit::sky_link::PublishedSource sun;
  sun.direction = Eigen::Vector3d(std::cos(azimuth), std::sin(azimuth), 1.5).normalized();
  sun.energy = Eigen::Vector3d(3.0, 2.9, 2.7) * drift;
  sun.angular_radius = 0.00465;
  m.sources.push_back(sun);
  m.sun_reason = "sun: synthetic";
  return m;
}

// What the nodes have done, waited on by the publisher.
struct Progress {
  std::mutex mutex;
  std::condition_variable changed;
  std::size_t warm = 0;       // nodes that blended the warm-up sky
  std::size_t settled = 0;    // timed skies blended or dropped, all nodes together
};

// One HMD node: its connection, its plane, and when each sky's blend finished.
struct Node {
  Plane plane;
  std::vector<float> T;
  std::optional<std::uint64_t> last_sequence;
  std::vector<std::optional<Clock::time_point>> finished;  // by sequence; 0 is the warm-up
  std::vector<double> handler_seconds;                     // decode + weights + blend, per sky
  std::size_t dropped = 0;
  std::string drop_detail;                                 // the first drop's reason and detail
  std::unique_ptr<MqttClient> client;                      // last: its thread ends before the rest goes
};

// The node's handler (its network thread): decode, blend, note the time. It never throws into
// libmosquitto: a sky the decoder or the blend refuses is counted as dropped.
void take_sky(Node& node, Progress& progress, const SkyIdentity& identity, std::span<const std::uint8_t> payload) {
  const auto received = Clock::now();
  std::optional<std::uint64_t> taken;
  std::string refused;
  try {
    const DecodedSky sky = decode_sky_message(payload, identity, node.last_sequence);
    if (sky.message) {
      const SkyMessage& m = *sky.message;
      std::optional<skylit::blend::SunLight> sun;
      if (!m.sources.empty()) sun = skylit::blend::SunLight{m.sources[0].direction, m.sources[0].energy};
      skylit::blend::BlendOptions options;
      options.threads = 1;  // the nodes share this machine's cores; a real node has its own
      const skylit::blend::BlendWeights weights = skylit::blend::blend_weights(node.plane.basis, m.S, sun, options);
      skylit::blend::blend_cpu(node.plane.basis, weights,
                               sun ? std::span<const float>(node.plane.visibility) : std::span<const float>(), node.T,
                               options);
      node.last_sequence = m.sequence;
      taken = m.sequence;
    } else {
      refused = std::string(skylit::sky_link::drop_reason_name(sky.dropped)) + ": " + sky.detail;
    }
  } catch (const std::exception& e) {
    refused = std::string("blend: ") + e.what();
  }
  const auto done = Clock::now();
  {
    std::lock_guard lock(progress.mutex);
    if (!taken) {
      ++node.dropped;
      if (node.drop_detail.empty()) node.drop_detail = refused;
      ++progress.settled;
    } else if (*taken == 0) {
      ++progress.warm;
    } else if (*taken < node.finished.size()) {
      node.finished[*taken] = done;
      node.handler_seconds.push_back(std::chrono::duration<double>(done - received).count());
      ++progress.settled;
    }
  }
  progress.changed.notify_all();
}

double percentile(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return std::nan("");
  const auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(sorted.size())));
  return sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
}

struct Row {
  int nodes = 0;
  std::size_t min_bytes = 0, max_bytes = 0;
  std::vector<double> latencies;  // seconds, sorted
  double handler_median = 0;      // seconds
  std::size_t unsent = 0;         // skies the sky node could not publish (not connected)
  std::size_t dropped = 0;
  std::size_t missed = 0;
  std::string drop_detail;
  double broker_cpu = 0;          // seconds
  double wall = 0;                // seconds, first publish to last blend
};

Row run(const Settings& settings, int node_count) {
  const SkyIdentity identity = bench_identity(settings);
  const auto skies = static_cast<std::size_t>(settings.skies);
  std::vector<std::vector<std::uint8_t>> messages;
  for (std::size_t s = 0; s <= skies; ++s) messages.push_back(encode_sky_message(make_sky(identity, s, settings.rate)));

  Broker broker(settings.mosquitto);
  const auto settings_for = [&](const std::string& id) {
    MqttSettings s;
    s.port = broker.port();
    s.client_id = id;
    s.reconnect_min_s = 0.1;
    s.reconnect_max_s = 1;
    return s;
  };
  MqttClient sky_node(settings_for("bench-sky-node"));
  if (!sky_node.wait_connected(10)) throw std::runtime_error("the sky node did not connect to " + sky_node.address());
  // Retained: a node that subscribes after it reaches the broker gets it at once.
  if (!sky_node.publish(kTopic, messages[0], /*retain=*/true)) throw std::runtime_error("warm-up sky not published");

  Progress progress;
  std::vector<std::unique_ptr<Node>> nodes;
  for (int n = 0; n < node_count; ++n) {
    auto node = std::make_unique<Node>();
    node->plane = make_plane(settings.plane_size, identity.layers, 1000 + static_cast<std::uint64_t>(n));
    node->T.resize(3 * node->plane.basis.texel_count());
    node->finished.resize(skies + 1);
    node->client = std::make_unique<MqttClient>(settings_for("bench-hmd-" + std::to_string(n)));
    Node& self = *node;
    node->client->subscribe(kTopic, [&self, &progress, &identity](const std::string&, std::span<const std::uint8_t> payload,
                                                                   bool) { take_sky(self, progress, identity, payload); });
    nodes.push_back(std::move(node));
  }
  {
    std::unique_lock lock(progress.mutex);
    const auto all_warm = [&] { return progress.warm == nodes.size(); };
    if (!progress.changed.wait_for(lock, std::chrono::seconds(30), all_warm)) {
      throw std::runtime_error(std::to_string(progress.warm) + " of " + std::to_string(nodes.size()) +
                               " nodes took the warm-up sky within 30 s");
    }
  }

  Row row;
  row.nodes = node_count;
  std::vector<std::optional<Clock::time_point>> sent(skies + 1);
  const double cpu_before = broker.cpu_seconds();
  const auto start = Clock::now();
  for (std::size_t s = 1; s <= skies; ++s) {
    std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                              std::chrono::duration<double>(static_cast<double>(s - 1) / settings.rate)));
    const auto at = Clock::now();
    if (sky_node.publish(kTopic, messages[s], /*retain=*/true)) {
      sent[s] = at;
    } else {
      ++row.unsent;
    }
  }
  // Every published sky blended or dropped by every node; what has not come 10 s after the last
  // publish is missed.
  const std::size_t expected = nodes.size() * (skies - row.unsent);
  {
    std::unique_lock lock(progress.mutex);
    progress.changed.wait_for(lock, std::chrono::seconds(10), [&] { return progress.settled >= expected; });
  }
  const double cpu_after = broker.cpu_seconds();
  std::optional<Clock::time_point> last;

  // The handlers are done with what is read below once their clients are gone.
  for (auto& node : nodes) node->client.reset();
  for (const auto& node : nodes) {
    row.dropped += node->dropped;
    if (row.drop_detail.empty()) row.drop_detail = node->drop_detail;
    for (std::size_t s = 1; s <= skies; ++s) {
      if (!sent[s]) continue;
      if (!node->finished[s]) continue;
      row.latencies.push_back(std::chrono::duration<double>(*node->finished[s] - *sent[s]).count());
      if (!last || *node->finished[s] > *last) last = node->finished[s];
    }
  }
  // A dropped sky is one that came; the rest of the pairs without a blend never came.
  const std::size_t unblended = expected - row.latencies.size();
  row.missed = unblended > row.dropped ? unblended - row.dropped : 0;
  std::vector<double> handler;
  for (const auto& node : nodes) handler.insert(handler.end(), node->handler_seconds.begin(), node->handler_seconds.end());
  std::sort(handler.begin(), handler.end());
  row.handler_median = percentile(handler, 0.5);
  std::sort(row.latencies.begin(), row.latencies.end());
  row.broker_cpu = cpu_after - cpu_before;
  row.wall = std::chrono::duration<double>(last.value_or(Clock::now()) - start).count();
  row.min_bytes = row.max_bytes = messages[1].size();
  for (std::size_t s = 1; s <= skies; ++s) {
    row.min_bytes = std::min(row.min_bytes, messages[s].size());
    row.max_bytes = std::max(row.max_bytes, messages[s].size());
  }
  return row;
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  double one = 0, five = 0, fifteen = 0;
  in >> one >> five >> fifteen;
  char text[64];
  std::snprintf(text, sizeof text, "%.2f %.2f %.2f", one, five, fifteen);
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"site_link_bench: sky latency from the sky node's publish to each HMD node's blend, over mosquitto"};
  Settings settings;
  app.add_option("--nodes", settings.nodes, "HMD node counts, one run each")->delimiter(',')->check(CLI::PositiveNumber);
  app.add_option("--skies", settings.skies, "timed skies per run")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--rate", settings.rate, "skies per second")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--plane-size", settings.plane_size, "texels per side of each node's plane")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--frequency", settings.frequency, "dome frequency ν (10ν² faces)")
      ->capture_default_str()
      ->check(CLI::Range(1, 16));
  app.add_option("--mosquitto", settings.mosquitto, "the broker program")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  const int layers = 10 * settings.frequency * settings.frequency;
  std::printf("site_link_bench: %d skies at %g Hz per run; each node blends one %d² plane of %d faces (ν %d, sun, "
              "1 thread, %s); %u hardware threads; load average at start %s\n\n",
              settings.skies, settings.rate, settings.plane_size, layers, settings.frequency,
              skylit::blend::blend_simd_available() ? "avx2" : "portable", std::thread::hardware_concurrency(),
              load_average().c_str());
  std::printf("| nodes | bytes/message | latency p50 | p99 | max | decode + blend p50 | dropped | missed | broker CPU | "
              "broker CPU / wall |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  std::fflush(stdout);
  std::vector<std::string> notes;
  for (const int n : settings.nodes) {
    const Row row = run(settings, n);
    const std::string bytes = row.min_bytes == row.max_bytes
                                  ? std::to_string(row.min_bytes)
                                  : std::to_string(row.min_bytes) + "–" + std::to_string(row.max_bytes);
    std::printf("| %d | %s | %.2f ms | %.2f ms | %.2f ms | %.3f ms | %zu | %zu | %.3f s | %.1f%% |\n", n, bytes.c_str(),
                percentile(row.latencies, 0.5) * 1e3, percentile(row.latencies, 0.99) * 1e3,
                row.latencies.empty() ? std::nan("") : row.latencies.back() * 1e3, row.handler_median * 1e3, row.dropped,
                row.missed, row.broker_cpu, 100.0 * row.broker_cpu / row.wall);
    std::fflush(stdout);
    if (row.unsent > 0) notes.push_back(std::to_string(n) + " nodes: " + std::to_string(row.unsent) + " skies not published");
    if (!row.drop_detail.empty()) notes.push_back(std::to_string(n) + " nodes: first drop: " + row.drop_detail);
  }
  std::printf("\nload average at the end %s\n", load_average().c_str());
  for (const std::string& note : notes) std::printf("%s\n", note.c_str());
  return 0;
}
