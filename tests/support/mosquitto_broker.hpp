#pragma once
// A real MQTT broker for a test: Debian's mosquitto on a loopback port picked free, with a config
// of its own (anonymous, no persistence); stop() and start() again on the same port model a
// broker restart. Stopped on destruction.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <thread>

#include "temp_dir.hpp"

namespace skylit::test {

class MosquittoBroker {
 public:
  static constexpr const char* kProgram = "/usr/sbin/mosquitto";

  // `settings`: the listener's lines after `listener PORT 127.0.0.1` (TLS files, a password file).
  explicit MosquittoBroker(const std::string& settings = "allow_anonymous true\n") : port_(free_port()) {
    if (!std::filesystem::exists(kProgram)) {
      throw std::runtime_error(std::string(kProgram) + " is missing: install Debian's mosquitto (scripts/install-deps.sh)");
    }
    config_ = dir_.write("mosquitto.conf", "listener " + std::to_string(port_) + " 127.0.0.1\n" + settings + "persistence false\n");
    start();
  }
  ~MosquittoBroker() { stop(); }
  MosquittoBroker(const MosquittoBroker&) = delete;
  MosquittoBroker& operator=(const MosquittoBroker&) = delete;

  int port() const { return port_; }

  // Starts the broker and waits until it accepts connections (10 s at most).
  void start() {
    if (pid_ > 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      const std::string log = (dir_ / "mosquitto.log").string();
      FILE* out = std::freopen(log.c_str(), "a", stderr);
      (void)out;
      ::execl(kProgram, kProgram, "-c", config_.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (!accepts()) {
      if (std::chrono::steady_clock::now() > deadline) throw std::runtime_error("mosquitto did not start on its port");
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }

 private:
  static int free_port() {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    address.sin_port = 0;
    socklen_t size = sizeof address;
    if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size) != 0) {
      throw std::runtime_error("no free loopback port");
    }
    ::close(fd);
    return ntohs(address.sin_port);
  }
  bool accepts() const {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    address.sin_port = htons(static_cast<std::uint16_t>(port_));
    const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
    ::close(fd);
    return ok;
  }

  TempDir dir_{"skylit_mosquitto_"};
  int port_;
  std::filesystem::path config_;
  pid_t pid_ = -1;
};

}  // namespace skylit::test
