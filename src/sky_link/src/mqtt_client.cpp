#include "skylit/sky_link/mqtt_client.hpp"

#include <mosquitto.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <algorithm>
#include <utility>
#include <vector>

#include "skylit/base/error.hpp"

namespace skylit::sky_link {
namespace {

// libmosquitto wants one init per process before any client; it is never cleaned up (other
// clients may still run).
void init_library_once() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });
}

}  // namespace

struct MqttClient::State {
  MqttSettings settings;
  mosquitto* client = nullptr;
  mutable std::mutex mutex;
  mutable std::condition_variable changed;
  bool connected = false;
  std::uint64_t connections = 0;
  std::string last_error;
  std::vector<std::pair<std::string, Handler>> subscriptions;
  // Until the first connection the starter thread tries with the backoff (libmosquitto's own
  // thread retries only a connection once made); then libmosquitto's thread takes over.
  std::thread starter;
  bool stopping = false;
  bool loop_running = false;

  void start() {
    double delay = settings.reconnect_min_s;
    while (true) {
      const int rc = mosquitto_connect(client, settings.host.c_str(), settings.port, settings.keepalive_s);
      std::unique_lock lock(mutex);
      if (stopping) return;
      last_error = rc == MOSQ_ERR_ERRNO ? std::strerror(errno) : mosquitto_strerror(rc);
      if (rc == MOSQ_ERR_SUCCESS) {
        last_error.clear();
        loop_running = mosquitto_loop_start(client) == MOSQ_ERR_SUCCESS;
        return;
      }
      changed.wait_for(lock, std::chrono::duration<double>(delay), [this] { return stopping; });
      if (stopping) return;
      delay = std::min(delay * 2, settings.reconnect_max_s);
    }
  }

  void on_connect(int rc) {
    std::vector<std::string> filters;
    {
      std::lock_guard lock(mutex);
      connected = rc == 0;
      if (connected) ++connections;
      last_error = connected ? std::string() : std::string("broker refused: ") + mosquitto_connack_string(rc);
      for (const auto& s : subscriptions) filters.push_back(s.first);
    }
    changed.notify_all();
    if (rc != 0) return;
    for (const std::string& f : filters) mosquitto_subscribe(client, nullptr, f.c_str(), 1);
  }
  void on_disconnect(int rc) {
    {
      std::lock_guard lock(mutex);
      connected = false;
      if (rc != 0 && last_error.empty()) last_error = "connection lost";
    }
    changed.notify_all();
  }
  void on_message(const mosquitto_message* m) {
    std::vector<Handler> handlers;
    {
      std::lock_guard lock(mutex);
      for (const auto& [filter, handler] : subscriptions) {
        bool matches = false;
        if (mosquitto_topic_matches_sub(filter.c_str(), m->topic, &matches) == MOSQ_ERR_SUCCESS && matches) {
          handlers.push_back(handler);
        }
      }
    }
    const std::span<const std::uint8_t> payload(static_cast<const std::uint8_t*>(m->payload),
                                                static_cast<std::size_t>(m->payloadlen));
    for (const Handler& h : handlers) h(m->topic, payload, m->retain);
  }
};

MqttClient::MqttClient(MqttSettings settings) : state_(std::make_unique<State>()) {
  if (settings.port < 1 || settings.port > 65535) {
    throw InputError("MQTT broker port " + std::to_string(settings.port) + ": outside 1..65535. Fix: give HOST:PORT");
  }
  if (settings.keepalive_s < 5) {
    throw InputError("MQTT keepalive " + std::to_string(settings.keepalive_s) + " s: under 5 s. Fix: 5 s or more");
  }
  init_library_once();
  State& s = *state_;
  s.settings = std::move(settings);
  const char* id = s.settings.client_id.empty() ? nullptr : s.settings.client_id.c_str();
  s.client = mosquitto_new(id, true, &s);
  if (s.client == nullptr) throw std::runtime_error("mosquitto_new failed");
  mosquitto_int_option(s.client, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
  if (!s.settings.username.empty()) {
    mosquitto_username_pw_set(s.client, s.settings.username.c_str(),
                              s.settings.password.empty() ? nullptr : s.settings.password.c_str());
  }
  if (const MqttTls& tls = s.settings.tls; !tls.ca_file.empty()) {
    // The broker's certificate is checked against ca_file; a client certificate is optional.
    const int rc = mosquitto_tls_set(s.client, tls.ca_file.c_str(), nullptr,
                                     tls.cert_file.empty() ? nullptr : tls.cert_file.c_str(),
                                     tls.key_file.empty() ? nullptr : tls.key_file.c_str(), nullptr);
    if (rc != MOSQ_ERR_SUCCESS) {
      mosquitto_destroy(s.client);
      throw InputError("MQTT TLS (ca_file " + tls.ca_file + (tls.cert_file.empty() ? "" : ", cert_file " + tls.cert_file) +
                       "): " + mosquitto_strerror(rc) + ". Fix: give readable PEM files (the key with its certificate)");
    }
  }
  if (s.settings.will) {
    const MqttWill& w = *s.settings.will;
    mosquitto_will_set(s.client, w.topic.c_str(), static_cast<int>(w.payload.size()), w.payload.data(), 1, w.retain);
  }
  const auto seconds = [](double x) { return static_cast<unsigned>(std::max(1.0, x + 0.5)); };
  mosquitto_reconnect_delay_set(s.client, seconds(s.settings.reconnect_min_s), seconds(s.settings.reconnect_max_s), true);
  mosquitto_connect_callback_set(s.client, [](mosquitto*, void* self, int rc) { static_cast<State*>(self)->on_connect(rc); });
  mosquitto_disconnect_callback_set(s.client, [](mosquitto*, void* self, int rc) { static_cast<State*>(self)->on_disconnect(rc); });
  mosquitto_message_callback_set(s.client, [](mosquitto*, void* self, const mosquitto_message* m) {
    static_cast<State*>(self)->on_message(m);
  });
  // A broker that is down now is reached later: the starter retries with the backoff.
  s.starter = std::thread([&s] { s.start(); });
}

MqttClient::~MqttClient() {
  State& s = *state_;
  {
    std::lock_guard lock(s.mutex);
    s.stopping = true;
  }
  s.changed.notify_all();
  s.starter.join();
  if (s.loop_running) {
    mosquitto_disconnect(s.client);
    mosquitto_loop_stop(s.client, false);
  }
  mosquitto_destroy(s.client);
}

void MqttClient::subscribe(const std::string& filter, Handler handler) {
  bool now = false;
  {
    std::lock_guard lock(state_->mutex);
    state_->subscriptions.emplace_back(filter, std::move(handler));
    now = state_->connected;
  }
  if (now) mosquitto_subscribe(state_->client, nullptr, filter.c_str(), 1);
}

bool MqttClient::publish(const std::string& topic, std::span<const std::uint8_t> payload, bool retain) {
  if (!connected()) return false;
  return mosquitto_publish(state_->client, nullptr, topic.c_str(), static_cast<int>(payload.size()), payload.data(), 1,
                           retain) == MOSQ_ERR_SUCCESS;
}

bool MqttClient::publish(const std::string& topic, const std::string& payload, bool retain) {
  return publish(topic, std::span(reinterpret_cast<const std::uint8_t*>(payload.data()), payload.size()), retain);
}

bool MqttClient::connected() const {
  std::lock_guard lock(state_->mutex);
  return state_->connected;
}

std::uint64_t MqttClient::connections() const {
  std::lock_guard lock(state_->mutex);
  return state_->connections;
}

bool MqttClient::wait_connected(double seconds) const {
  std::unique_lock lock(state_->mutex);
  return state_->changed.wait_for(lock, std::chrono::duration<double>(seconds), [this] { return state_->connected; });
}

std::string MqttClient::address() const {
  return state_->settings.host + ":" + std::to_string(state_->settings.port);
}

std::string MqttClient::last_error() const {
  std::lock_guard lock(state_->mutex);
  return state_->last_error;
}

}  // namespace skylit::sky_link
