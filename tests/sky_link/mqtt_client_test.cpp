// The MQTT link against a real broker (Debian's mosquitto on a loopback port): a retained sky
// reaches a node that joins later, a broker that is down at start or restarts is reached again
// with the subscriptions back, and a node that vanishes leaves its last will.
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <thread>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "skylit/base/error.hpp"
#include "skylit/sky_link/mqtt_client.hpp"
#include "skylit/sky_link/sky_message.hpp"
#include "../support/mosquitto_broker.hpp"
#include "../support/temp_dir.hpp"

namespace skylit::sky_link {
namespace {

using test::MosquittoBroker;

// Messages received on the network thread, waited for by the test.
class Inbox {
 public:
  MqttClient::Handler handler() {
    return [this](const std::string& topic, std::span<const std::uint8_t> payload, bool retained) {
      {
        std::lock_guard lock(mutex_);
        messages_.push_back({topic, std::vector<std::uint8_t>(payload.begin(), payload.end()), retained});
      }
      changed_.notify_all();
    };
  }
  struct Message {
    std::string topic;
    std::vector<std::uint8_t> payload;
    bool retained = false;
  };
  // The count-th message (1-based) once it is there, within `timeout`.
  std::optional<Message> wait_for(std::size_t count, std::chrono::milliseconds timeout = std::chrono::seconds(15)) {
    std::unique_lock lock(mutex_);
    if (!changed_.wait_for(lock, timeout, [&] { return messages_.size() >= count; })) return std::nullopt;
    return messages_[count - 1];
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Message> messages_;
};

MqttSettings at(const MosquittoBroker& broker, const std::string& id) {
  MqttSettings s;
  s.port = broker.port();
  s.client_id = id;
  s.reconnect_min_s = 0.1;
  s.reconnect_max_s = 1;
  s.keepalive_s = 5;
  return s;
}

std::string text(const std::vector<std::uint8_t>& bytes) { return std::string(bytes.begin(), bytes.end()); }

TEST(MqttClient, ARetainedSkyReachesANodeThatJoinsLater) {
  MosquittoBroker broker;
  SkyMessage sky;
  sky.identity = {"sample gate", 2, geom::DomeBasis::Faces, 2};
  sky.sequence = 5;
  sky.S = {Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(0.25, 0.5, 0.125)};
  const std::vector<std::uint8_t> bytes = encode_sky_message(sky);
  {
    MqttClient sky_node(at(broker, "sky-node"));
    ASSERT_TRUE(sky_node.wait_connected(15));
    ASSERT_TRUE(sky_node.publish("skylit/sample/sky", bytes, /*retain=*/true));
  }
  MqttClient hmd(at(broker, "hmd-1"));
  Inbox inbox;
  hmd.subscribe("skylit/sample/sky", inbox.handler());
  ASSERT_TRUE(hmd.wait_connected(15));
  const auto got = inbox.wait_for(1);
  ASSERT_TRUE(got);
  EXPECT_TRUE(got->retained);
  const DecodedSky decoded = decode_sky_message(got->payload, sky.identity, std::nullopt);
  ASSERT_TRUE(decoded.message) << decoded.detail;
  EXPECT_EQ(decoded.message->sequence, 5u);
  EXPECT_EQ(decoded.message->S[1], Eigen::Vector3d(0.25, 0.5, 0.125));
}

TEST(MqttClient, ABrokerDownAtStartOrRestartingIsReachedAgainWithTheSubscriptions) {
  MosquittoBroker broker;
  broker.stop();
  MqttClient hmd(at(broker, "hmd-1"));
  Inbox inbox;
  hmd.subscribe("skylit/sample/#", inbox.handler());
  EXPECT_FALSE(hmd.connected());
  EXPECT_FALSE(hmd.publish("skylit/sample/nodes/hmd-1", std::string("online"), true));

  broker.start();
  ASSERT_TRUE(hmd.wait_connected(15));
  EXPECT_EQ(hmd.connections(), 1u);

  broker.stop();
  broker.start();
  // Connected again (a second connection), and subscribed again: a new message reaches it.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  while (hmd.connections() < 2 && std::chrono::steady_clock::now() < deadline) hmd.wait_connected(0.1);
  ASSERT_EQ(hmd.connections(), 2u);
  MqttClient sky_node(at(broker, "sky-node"));
  ASSERT_TRUE(sky_node.wait_connected(15));
  // The resubscription may reach the broker after the node's first message (which, not
  // retained, is then gone): publish until one arrives, as a node publishing skies would.
  std::optional<Inbox::Message> got;
  for (int attempt = 0; attempt < 75 && !got; ++attempt) {
    ASSERT_TRUE(sky_node.publish("skylit/sample/sky", std::string("after the restart"), false));
    got = inbox.wait_for(1, std::chrono::milliseconds(200));
  }
  ASSERT_TRUE(got);
  EXPECT_EQ(got->topic, "skylit/sample/sky");
  EXPECT_EQ(text(got->payload), "after the restart");
}

TEST(MqttClient, ANodeThatVanishesLeavesItsLastWill) {
  MosquittoBroker broker;
  // The node runs in a child process that ends without saying goodbye, as a crash would.
  const pid_t child = ::fork();
  if (child == 0) {
    MqttSettings s = at(broker, "sky-node");
    s.will = MqttWill{"skylit/sample/nodes/sky-node", "offline", true};
    MqttClient node(s);
    ::_exit(node.wait_connected(15) && node.publish("skylit/sample/nodes/sky-node", std::string("online"), true) ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);

  MqttClient watcher(at(broker, "console"));
  Inbox inbox;
  watcher.subscribe("skylit/sample/nodes/+", inbox.handler());
  ASSERT_TRUE(watcher.wait_connected(15));
  // The retained state ends as the will: "offline" (after "online", or at once if the broker
  // had already sent the will when the watcher subscribed).
  for (std::size_t n = 1;; ++n) {
    const auto got = inbox.wait_for(n);
    ASSERT_TRUE(got) << "no will within 15 s";
    EXPECT_EQ(got->topic, "skylit/sample/nodes/sky-node");
    if (text(got->payload) == "offline") break;
    EXPECT_EQ(text(got->payload), "online");
  }
}

TEST(MqttClient, SettingsThatCanNeverWorkAreInputErrors) {
  MqttSettings s;
  s.port = 70000;
  EXPECT_THROW(MqttClient{s}, InputError);
  s.port = 1883;
  s.keepalive_s = 1;
  EXPECT_THROW(MqttClient{s}, InputError);
}

// A locked-down broker (docs/site.md, "TLS and credentials"): TLS with a certificate of a test
// authority, no anonymous clients, mosquitto's own password file. The credentials and the
// authority pass through to the broker: the right ones connect, a wrong password is told why.
TEST(MqttClient, TlsAndAPasswordFileArePassedToTheBroker) {
  const test::TempDir dir("skylit_tls_");
  const std::string d = dir.path().string();
  const std::string make =
      "cd '" + d + "' && openssl req -x509 -newkey rsa:2048 -nodes -keyout ca.key -out ca.crt -days 2 -subj /CN=skylit-test-ca "
      "&& openssl req -newkey rsa:2048 -nodes -keyout broker.key -out broker.csr -subj /CN=127.0.0.1 "
      "&& printf 'subjectAltName=IP:127.0.0.1' > san && openssl x509 -req -in broker.csr -CA ca.crt -CAkey ca.key "
      "-CAcreateserial -out broker.crt -days 2 -extfile san && mosquitto_passwd -b -c passwd sky-node right-secret "
      "&& chmod 755 . && chmod 644 *";  // mosquitto may read them as its own user
  ASSERT_EQ(std::system(("(" + make + ") > '" + d + "/make.log' 2>&1").c_str()), 0) << "openssl or mosquitto_passwd failed: see " << d << "/make.log";
  MosquittoBroker broker("cafile " + d + "/ca.crt\ncertfile " + d + "/broker.crt\nkeyfile " + d +
                         "/broker.key\nallow_anonymous false\npassword_file " + d + "/passwd\n");

  MqttSettings right = at(broker, "sky-node");
  right.username = "sky-node";
  right.password = "right-secret";
  right.tls.ca_file = d + "/ca.crt";
  MqttClient node(right);
  Inbox inbox;
  node.subscribe("skylit/tls/sky", inbox.handler());
  ASSERT_TRUE(node.wait_connected(15)) << node.last_error();
  // Retained: the subscription may reach the broker after this publish.
  ASSERT_TRUE(node.publish("skylit/tls/sky", std::string("over TLS"), true));
  const auto got = inbox.wait_for(1);
  ASSERT_TRUE(got);
  EXPECT_EQ(text(got->payload), "over TLS");

  MqttSettings wrong = right;
  wrong.client_id = "intruder";
  wrong.password = "wrong-secret";
  MqttClient intruder(wrong);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  while (intruder.last_error().empty() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_FALSE(intruder.connected());
  EXPECT_NE(intruder.last_error().find("not authori"), std::string::npos) << intruder.last_error();

  MqttSettings anonymous = at(broker, "anonymous");  // TLS but no user: refused too
  anonymous.tls.ca_file = d + "/ca.crt";
  MqttClient stranger(anonymous);
  const auto deadline2 = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  while (stranger.last_error().empty() && std::chrono::steady_clock::now() < deadline2) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_FALSE(stranger.connected());

  MqttSettings missing = right;
  missing.tls.ca_file = d + "/no-such-ca.crt";
  EXPECT_THROW(MqttClient{missing}, InputError);
}

}  // namespace
}  // namespace skylit::sky_link
