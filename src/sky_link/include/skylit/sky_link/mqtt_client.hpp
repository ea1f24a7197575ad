#pragma once
// One connection to an MQTT broker (libmosquitto, MQTT 3.1.1) with its own network thread:
// publish, subscribe with a handler, a last will, reconnection with backoff. A broker that is
// down is never an error: the client keeps trying and says so in connected() and reconnects().
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>

namespace skylit::sky_link {

struct MqttWill {
  std::string topic;
  std::string payload;
  bool retain = true;
};

// TLS to the broker (mosquitto's listener with cafile/certfile/keyfile): off while ca_file is empty.
struct MqttTls {
  std::string ca_file;    // PEM: the authority the broker's certificate is checked against
  std::string cert_file;  // PEM: this client's certificate, for a broker that requires one
  std::string key_file;   // PEM: its key (unencrypted)
};

struct MqttSettings {
  std::string host = "127.0.0.1";
  int port = 1883;
  std::string client_id;          // empty: the broker picks one
  std::string username;           // empty: anonymous
  std::string password;
  MqttTls tls;
  std::optional<MqttWill> will;   // sent by the broker when this client vanishes without a goodbye
  int keepalive_s = 10;           // the broker declares the client gone after 1.5 × this of silence
  double reconnect_min_s = 0.5;   // backoff between attempts, doubling up to the max
  double reconnect_max_s = 30;
};

class MqttClient {
 public:
  // topic, payload, whether the broker kept it (retained); called on the network thread.
  using Handler = std::function<void(const std::string& topic, std::span<const std::uint8_t> payload, bool retained)>;

  // Starts connecting in the background. InputError only for settings that can never work
  // (a port outside 1..65535, a keepalive under 5 s).
  explicit MqttClient(MqttSettings settings);
  ~MqttClient();  // says goodbye (no will) and stops the network thread
  MqttClient(const MqttClient&) = delete;
  MqttClient& operator=(const MqttClient&) = delete;

  // `filter` may hold + and # wildcards; subscribed again after every reconnection.
  void subscribe(const std::string& filter, Handler handler);
  // Queued while disconnected is not done: false when not connected (the caller keeps its latest
  // value and publishes it again on the next change or reconnection).
  bool publish(const std::string& topic, std::span<const std::uint8_t> payload, bool retain);
  bool publish(const std::string& topic, const std::string& payload, bool retain);

  bool connected() const;
  std::uint64_t connections() const;  // successful connections so far (1 after the first)
  // Blocks until connected or `seconds` passed; true when connected.
  bool wait_connected(double seconds) const;
  std::string address() const;      // "host:port"
  // Why the last attempt failed or the connection ended ("connection refused", "not authorised");
  // empty while connected.
  std::string last_error() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace skylit::sky_link
