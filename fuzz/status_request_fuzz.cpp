// Requests to the status server (live::StatusServer, the console's and Prometheus' endpoint),
// sent over loopback as raw bytes: request line, path, query, headers, cookies, token. Served
// by cpp-httplib and skylit's handlers; any request leaves the server answering.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>

#include "fuzz_target.hpp"
#include "skylit/live/status_server.hpp"

namespace {

// A client socket to 127.0.0.1:port, closed at scope end; -1 when the server cannot be reached.
class Connection {
 public:
  explicit Connection(int port) : fd_(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0)) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    timeval timeout{2, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
    if (::connect(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
      ::close(fd_);
      fd_ = -1;
    }
  }
  ~Connection() {
    if (fd_ >= 0) ::close(fd_);
  }
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;
  int fd() const { return fd_; }

  // Sends `request` (ending the writing side when `half_close`) and reads the answer until the
  // server closes.
  std::string exchange(const std::string& request, bool half_close) {
    std::size_t sent = 0;
    while (sent < request.size()) {
      const ssize_t n = ::send(fd_, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) break;
      sent += static_cast<std::size_t>(n);
    }
    if (half_close) ::shutdown(fd_, SHUT_WR);
    std::string answer;
    char buffer[4096];
    for (ssize_t n; (n = ::recv(fd_, buffer, sizeof buffer, 0)) > 0;) answer.append(buffer, static_cast<std::size_t>(n));
    return answer;
  }

 private:
  int fd_;
};

skylit::live::StatusHandlers handlers() {
  skylit::live::StatusHandlers h;
  h.status_json = [] { return std::string("{\"state\": \"running\"}\n"); };
  h.metrics_text = [] { return skylit::live::prometheus_text({{"skylit_frames_total", "Frames.", "counter", 1, ""}}); };
  h.sky_jpeg = [] { return std::vector<std::uint8_t>{0xff, 0xd8, 0xff, 0xd9}; };
  h.frame_jpeg = [] { return std::vector<std::uint8_t>(); };
  h.site_json = [] { return std::string("{}\n"); };
  h.bake_json = [] { return std::string("{}\n"); };
  h.history_json = [] { return std::string("[]\n"); };
  h.map_json = [] { return std::string("{}\n"); };
  h.bake_preview = [](const std::string& name) {
    skylit::fuzz::require(!name.empty() && name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-") ==
                                               std::string::npos,
                          "a preview's name is letters, digits, '_' and '-'");
    return std::vector<std::uint8_t>{0x89, 'P', 'N', 'G'};
  };
  h.token = "fuzz-token";
  return h;
}

}  // namespace

SKYLIT_FUZZ_TARGET(status_request) {
  static const auto server = std::make_unique<skylit::live::StatusServer>("127.0.0.1", 0, handlers());
  // The first byte picks a request line with a known path, so the handlers past the router are
  // reached; the rest is sent as it is (path, query, headers and body).
  static constexpr const char* kStarts[] = {"", "GET /", "GET /status", "GET /bake/preview/", "GET /metrics?",
                                            "POST /login", "GET /console.json", "GET /sky.jpg"};
  if (size == 0) return 0;
  std::string request = kStarts[data[0] % (sizeof kStarts / sizeof kStarts[0])];
  request.append(reinterpret_cast<const char*>(data + 1), size - 1);
  {
    Connection connection(server->port());
    skylit::fuzz::require(connection.fd() >= 0, "the server accepts connections");
    connection.exchange(request, true);
  }
  // The server caps its connections: while it finishes earlier ones a new one may be closed at
  // once. It must answer again within a few seconds.
  std::string answer;
  for (int attempt = 0; attempt < 50 && answer.rfind("HTTP/1.1 200", 0) != 0; ++attempt) {
    if (attempt > 0) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    Connection probe(server->port());
    if (probe.fd() < 0) continue;
    answer = probe.exchange("GET /status HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer fuzz-token\r\nConnection: close\r\n\r\n", false);
  }
  if (answer.rfind("HTTP/1.1 200", 0) != 0) std::fprintf(stderr, "the answer to GET /status: %s\n", answer.c_str());
  skylit::fuzz::require(answer.rfind("HTTP/1.1 200", 0) == 0, "the server still answers /status");
  return 0;
}
