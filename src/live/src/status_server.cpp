#include "skylit/live/status_server.hpp"

#include <httplib.h>

#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <set>
#include <thread>

#include "skylit/base/embedded_file.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit {
const EmbeddedFile* console_file(std::string_view name);  // src/live/console, built in
}

namespace skylit::live {

struct StatusServer::State {
  httplib::Server server;
  StatusHandlers handlers;
  std::string host;
  int port = 0;
  std::thread thread;
};

namespace {

constexpr const char* kTokenCookie = "skylit_token";
constexpr std::size_t kServerThreads = 8;  // a browser keeps up to 6 connections, each holding one while alive
constexpr std::size_t kMaxRequestBody = 16 * 1024;
constexpr time_t kTimeoutSeconds = 5;
constexpr time_t kKeepAliveSeconds = 2;

// Equal without a timing that tells how much of a guess was right.
bool same_secret(const std::string& a, const std::string& b) {
  unsigned char differ = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < a.size(); ++i) differ |= static_cast<unsigned char>(a[i] ^ b[i % (b.empty() ? 1 : b.size())]);
  return differ == 0 && !b.empty();
}

// The token a request carries: Authorization: Bearer TOKEN, or the login form's cookie.
std::string carried_token(const httplib::Request& request) {
  const std::string authorization = request.get_header_value("Authorization");
  if (authorization.rfind("Bearer ", 0) == 0) return authorization.substr(7);
  const std::string cookies = request.get_header_value("Cookie");
  const std::string key = std::string(kTokenCookie) + "=";
  for (std::size_t start = 0; start < cookies.size();) {
    const std::size_t end = std::min(cookies.find(';', start), cookies.size());
    std::string pair = cookies.substr(start, end - start);
    pair.erase(0, pair.find_first_not_of(' '));
    if (pair.rfind(key, 0) == 0) return pair.substr(key.size());
    start = end + 1;
  }
  return {};
}

std::string login_page(const std::string& title, bool failed) {
  return "<!doctype html><html lang=en><meta charset=utf-8><meta name=viewport content='width=device-width,initial-scale=1'>"
         "<title>" + title + ": sign in</title><link rel=stylesheet href=/console.css>"
         "<body class=login><main><h1>" + title + "</h1>"
         "<p>This console shows the HMD's camera: it asks for the site's console token (status.token_file).</p>" +
         (failed ? "<p class=problem role=alert>That token is not this console's.</p>" : "") +
         "<form id=login method=post action=/login><label for=token>Token</label>"
         "<input id=token name=token type=password autocomplete=current-password autofocus required>"
         "<button type=submit>Sign in</button></form></main></body></html>";
}

void serve_file(const EmbeddedFile* file, const char* type, httplib::Response& response) {
  if (file == nullptr) {
    response.status = 404;
    return;
  }
  response.set_header("Cache-Control", "no-cache");
  response.set_content(std::string(file->bytes), type);
}

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
  // The console (docs/console.md): one page, its style and script, built into the program.
  s->server.Get("/", [](const httplib::Request&, httplib::Response& response) {
    serve_file(console_file("index.html"), "text/html; charset=utf-8", response);
  });
  s->server.Get("/console.css", [](const httplib::Request&, httplib::Response& response) {
    serve_file(console_file("console.css"), "text/css; charset=utf-8", response);
  });
  s->server.Get("/console.js", [](const httplib::Request&, httplib::Response& response) {
    serve_file(console_file("console.js"), "text/javascript; charset=utf-8", response);
  });
  s->server.Get("/console.json", [s](const httplib::Request&, httplib::Response& response) {
    // What the page needs to know of its server before the first status.
    response.set_content(std::string("{\"title\": \"") + s->handlers.title + "\", \"site\": " +
                             (s->handlers.site_json ? "true" : "false") + ", \"frame\": " +
                             (s->handlers.frame_jpeg ? "true" : "false") + ", \"bake\": " +
                             (s->handlers.bake_json ? "true" : "false") + ", \"map\": " + (s->handlers.map_json ? "true" : "false") + "}",
                         "application/json");
  });
  if (s->handlers.bake_json) {
    s->server.Get("/bake.json", [s](const httplib::Request&, httplib::Response& response) {
      response.set_content(s->handlers.bake_json(), "application/json");
    });
  }
  if (s->handlers.history_json) {
    s->server.Get("/history.json", [s](const httplib::Request&, httplib::Response& response) {
      response.set_header("Cache-Control", "no-store");
      response.set_content(s->handlers.history_json(), "application/json");
    });
  }
  if (s->handlers.map_json) {
    s->server.Get("/map.json", [s](const httplib::Request&, httplib::Response& response) {
      response.set_content(s->handlers.map_json(), "application/json");
    });
  }
  if (s->handlers.bake_preview) {
    s->server.Get(R"(/bake/preview/([A-Za-z0-9_-]+)\.png)", [s](const httplib::Request& request, httplib::Response& response) {
      const std::vector<std::uint8_t> bytes = s->handlers.bake_preview(request.matches[1]);
      if (bytes.empty()) {
        response.status = 404;
        return;
      }
      response.set_content(std::string(bytes.begin(), bytes.end()), "image/png");
    });
  }
  // Off loopback, the token: the login form sets it as a cookie; every other page asks for it.
  if (!s->handlers.token.empty()) {
    s->server.Post("/login", [s](const httplib::Request& request, httplib::Response& response) {
      if (!same_secret(request.get_param_value("token"), s->handlers.token)) {
        response.status = 401;
        response.set_content(login_page(s->handlers.title, true), "text/html; charset=utf-8");
        return;
      }
      response.set_header("Set-Cookie", std::string(kTokenCookie) + "=" + s->handlers.token +
                                            "; Path=/; HttpOnly; SameSite=Strict; Max-Age=43200");
      response.set_redirect("/", 303);
    });
    s->server.set_pre_routing_handler([s](const httplib::Request& request, httplib::Response& response) {
      if (request.path == "/login" || request.path == "/console.css") return httplib::Server::HandlerResponse::Unhandled;
      if (same_secret(carried_token(request), s->handlers.token)) return httplib::Server::HandlerResponse::Unhandled;
      response.status = 401;
      if (request.path == "/") {
        response.set_content(login_page(s->handlers.title, false), "text/html; charset=utf-8");
      } else {
        response.set_header("WWW-Authenticate", "Bearer");
        response.set_content("the console's token is needed: Authorization: Bearer TOKEN, or sign in at /\n", "text/plain");
      }
      return httplib::Server::HandlerResponse::Handled;
    });
  }
  // No client can take more than its share (docs/console.md, "Access"): a few threads serve the
  // requests (the render loop keeps its cores), a request body is a login form at most, and a
  // slow or idle connection is closed.
  s->server.new_task_queue = [] { return new httplib::ThreadPool(kServerThreads); };
  s->server.set_payload_max_length(kMaxRequestBody);
  s->server.set_read_timeout(kTimeoutSeconds, 0);
  s->server.set_write_timeout(kTimeoutSeconds, 0);
  s->server.set_keep_alive_timeout(kKeepAliveSeconds);  // an idle connection frees its thread soon
  s->server.set_keep_alive_max_count(100);
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
  std::set<std::string> summaries;
  const auto in_summary = [&](const std::string& name) {
    // A summary's _sum and _count samples belong to its family: no HELP or TYPE of their own.
    for (const char* suffix : {"_sum", "_count"}) {
      const std::string s(suffix);
      if (name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0 &&
          summaries.count(name.substr(0, name.size() - s.size())) > 0) {
        return true;
      }
    }
    return false;
  };
  for (const Metric& m : metrics) {
    if (m.type == "summary" && !in_summary(m.name)) summaries.insert(m.name);
    if (!in_summary(m.name) && described.insert(m.name).second) {
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

bool is_loopback_address(const std::string& host) {
  return host == "localhost" || host == "::1" || host == "[::1]" || host.rfind("127.", 0) == 0;
}

std::string status_token(const std::string& host, const std::filesystem::path& token_file, bool allow_unauthenticated,
                         const std::string& program) {
  if (!token_file.empty()) {
    std::string token = read_file(token_file);
    while (!token.empty() && (token.back() == '\n' || token.back() == '\r' || token.back() == ' ')) token.pop_back();
    if (token.size() < 8) {
      throw InputError("status.token_file " + token_file.string() + ": the token is " + std::to_string(token.size()) +
                       " characters. Fix: write a longer secret, e.g. head -c 24 /dev/urandom | base64 > " +
                       token_file.string());
    }
    return token;
  }
  if (is_loopback_address(host)) return {};
  if (!allow_unauthenticated) {
    throw InputError("status.listen " + host + ": the console is reachable from other machines and shows the HMD's "
                     "camera (visitors, staff). Fix: set status.token_file: FILE (a secret: head -c 24 /dev/urandom | "
                     "base64 > FILE), or listen on 127.0.0.1, or set status.allow_unauthenticated: true on purpose");
  }
  std::fprintf(stderr, "%s: warning: the console on %s is open to anyone who reaches it (status.allow_unauthenticated)\n",
               program.c_str(), host.c_str());
  return {};
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
