#pragma once
// The service's status over HTTP: the console at / (docs/console.md), /status (JSON), /metrics
// (Prometheus), /sky.jpg, /frame.jpg, /bake.json and the bake's previews. Answers come from
// callbacks on the server's own thread (they must be thread-safe). cpp-httplib stays in the .cpp.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace skylit::live {

struct StatusHandlers {
  std::function<std::string()> status_json;
  std::function<std::string()> metrics_text;
  std::function<std::vector<std::uint8_t>()> sky_jpeg;    // empty: 503 (no sky yet)
  std::function<std::vector<std::uint8_t>()> frame_jpeg;  // empty: 503 (no frame yet)
  std::function<std::string()> site_json;                 // /site (the sky node): unset, no such page
  std::function<std::string()> bake_json;                 // /bake.json: unset, no such page
  std::function<std::string()> history_json;              // /history.json: the last minutes, for the plots
  std::function<std::string()> map_json;                  // /map.json: the site from above (planes, marker tags)
  // /bake/preview/NAME.png: the bake's preview image NAME (letters, digits, '_', '-'); empty: 404.
  std::function<std::vector<std::uint8_t>(const std::string& name)> bake_preview;
  std::string title = "skylit-live";                      // the console's
  std::string token;  // non-empty: every page but the login form asks for it (bearer or cookie)
};

// An address only this machine reaches (127.0.0.0/8, ::1, localhost): no token needed there.
bool is_loopback_address(const std::string& host);

// The console's token for a status server on `host`: the token file's text (trailing newline
// stripped); none on loopback without one. InputError naming status.token_file when `host` is
// reachable from elsewhere and there is no token, unless access.allow_unauthenticated (then a
// warning on stderr, naming `program`).
std::string status_token(const std::string& host, const std::filesystem::path& token_file, bool allow_unauthenticated,
                         const std::string& program);

class StatusServer {
 public:
  // Listens on address:port (port 0 picks a free one) in a thread of its own. Throws InputError
  // when the address cannot be bound, naming it and the fix.
  StatusServer(const std::string& address, int port, StatusHandlers handlers);
  ~StatusServer();  // stops listening and joins the thread
  StatusServer(const StatusServer&) = delete;
  StatusServer& operator=(const StatusServer&) = delete;

  int port() const;              // the port bound
  std::string address() const;   // "127.0.0.1:8080"

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// One sample of the Prometheus text format.
struct Metric {
  std::string name;   // skylit_..., [a-zA-Z_:][a-zA-Z0-9_:]*
  std::string help;
  std::string type;   // "counter", "gauge" or "summary" (its NAME_sum and NAME_count samples follow its quantiles)
  double value = 0;
  std::string labels; // optional, already formatted: face="3",channel="r"
};

// Metrics as Prometheus text: one HELP and TYPE line per name (first occurrence), then samples.
std::string prometheus_text(const std::vector<Metric>& metrics);

// "ADDR:PORT" → address and port; throws InputError naming `what` (e.g. "--status") and the fix.
std::pair<std::string, int> parse_listen_address(const std::string& text, const std::string& what);

}  // namespace skylit::live
