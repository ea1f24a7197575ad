#include "skylit/live/status_server.hpp"

#include <httplib.h>

#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <set>
#include <thread>

#include "skylit/base/error.hpp"

namespace skylit::live {

struct StatusServer::State {
  httplib::Server server;
  StatusHandlers handlers;
  std::string host;
  int port = 0;
  std::thread thread;
};

namespace {

void serve_jpeg(const std::function<std::vector<std::uint8_t>()>& source, httplib::Response& response) {
  const std::vector<std::uint8_t> bytes = source ? source() : std::vector<std::uint8_t>{};
  if (bytes.empty()) {
    response.status = 503;
    response.set_content("no image yet\n", "text/plain");
    return;
  }
  response.set_header("Cache-Control", "no-store");
  response.set_content(std::string(bytes.begin(), bytes.end()), "image/jpeg");
}

}  // namespace

StatusServer::StatusServer(const std::string& address, int port, StatusHandlers handlers)
    : state_(std::make_unique<State>()) {
  state_->handlers = std::move(handlers);
  state_->host = address;
  State* s = state_.get();
  s->server.Get("/status", [s](const httplib::Request&, httplib::Response& response) {
    response.set_header("Cache-Control", "no-store");
    response.set_content(s->handlers.status_json ? s->handlers.status_json() : "{}", "application/json");
  });
  s->server.Get("/metrics", [s](const httplib::Request&, httplib::Response& response) {
    response.set_content(s->handlers.metrics_text ? s->handlers.metrics_text() : "",
                         "text/plain; version=0.0.4; charset=utf-8");
  });
  s->server.Get("/sky.jpg", [s](const httplib::Request&, httplib::Response& response) {
    serve_jpeg(s->handlers.sky_jpeg, response);
  });
  s->server.Get("/frame.jpg", [s](const httplib::Request&, httplib::Response& response) {
    serve_jpeg(s->handlers.frame_jpeg, response);
  });
  if (s->handlers.site_json) {
    s->server.Get("/site", [s](const httplib::Request&, httplib::Response& response) {
      response.set_header("Cache-Control", "no-store");
      response.set_content(s->handlers.site_json(), "application/json");
    });
  }
  s->server.Get("/", [s](const httplib::Request&, httplib::Response& response) {
    const std::string& title = s->handlers.title;
    response.set_content("<!doctype html><title>" + title + "</title><h1>" + title +
                             "</h1><p><a href=/status>/status</a> · <a href=/metrics>/metrics</a>" +
                             (s->handlers.site_json ? " · <a href=/site>/site</a>" : "") + "</p>" +
                             (s->handlers.frame_jpeg ? "<img src=/frame.jpg width=640> " : "") + "<img src=/sky.jpg width=320>",
                         "text/html");
  });
  // SO_REUSEADDR only: httplib's default adds SO_REUSEPORT, which would let a second service
  // share the port silently instead of failing.
  s->server.set_socket_options([](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  if (port == 0) {
    s->port = s->server.bind_to_any_port(address);
  } else {
    s->port = s->server.bind_to_port(address, port) ? port : -1;
  }
  if (s->port <= 0) {
    throw InputError("status: cannot listen on " + address + ":" + std::to_string(port) +
                     " (the port is in use or the address is not this machine's); fix: choose another "
                     "ADDR:PORT with --status or status.listen in the config");
  }
  s->thread = std::thread([s] { s->server.listen_after_bind(); });
  // stop() is a no-op until the server runs: wait for it, so that a server destroyed at once
  // still ends its thread.
  while (!s->server.is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

StatusServer::~StatusServer() {
  if (!state_) return;
  state_->server.stop();
  if (state_->thread.joinable()) state_->thread.join();
}

int StatusServer::port() const { return state_->port; }
std::string StatusServer::address() const { return state_->host + ":" + std::to_string(state_->port); }

std::string prometheus_text(const std::vector<Metric>& metrics) {
  std::string out;
  std::set<std::string> described;
  for (const Metric& m : metrics) {
    if (described.insert(m.name).second) {
      out += "# HELP " + m.name + " " + m.help + "\n";
      out += "# TYPE " + m.name + " " + m.type + "\n";
    }
    out += m.name;
    if (!m.labels.empty()) out += "{" + m.labels + "}";
    char value[64];
    if (std::isnan(m.value)) {
      std::snprintf(value, sizeof value, "NaN");
    } else if (std::isinf(m.value)) {
      std::snprintf(value, sizeof value, m.value > 0 ? "+Inf" : "-Inf");
    } else {
      std::snprintf(value, sizeof value, "%.9g", m.value);
    }
    out += std::string(" ").append(value).append("\n");
  }
  return out;
}

std::pair<std::string, int> parse_listen_address(const std::string& text, const std::string& what) {
  const auto colon = text.rfind(':');
  int port = -1;
  if (colon != std::string::npos && colon > 0) {
    const char* begin = text.data() + colon + 1;
    const char* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(begin, end, port);
    if (ec != std::errc() || ptr != end) port = -1;
  }
  if (port < 0 || port > 65535) {
    throw InputError(what + ": '" + text + "' is not ADDR:PORT; fix: e.g. 127.0.0.1:8080 (port 0 picks a free one)");
  }
  return {text.substr(0, colon), port};
}

}  // namespace skylit::live
