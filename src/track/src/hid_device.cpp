// The hidapi backend: enumerate HID devices, open the one a profile matches, read its input
// reports in a thread of its own, and reopen it after an unplug.
#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <mutex>
#include <stop_token>
#include <thread>

#include <hidapi/hidapi.h>

#include "skylit/base/error.hpp"
#include "skylit/track/hid_imu.hpp"

namespace skylit::track {
namespace {

struct DeviceCloser {
  void operator()(hid_device* device) const { hid_close(device); }
};
using DeviceHandle = std::unique_ptr<hid_device, DeviceCloser>;

struct EnumerationFree {
  void operator()(hid_device_info* list) const { hid_free_enumeration(list); }
};

// hid_init is idempotent; hid_exit is never called, as it would pull the library from under
// any other user in the process (it holds nothing that outlives the process).
bool hidapi_ready() { return hid_init() == 0; }

std::string utf8(const wchar_t* text) {
  std::string out;
  if (text == nullptr) return out;
  for (; *text; ++text) {
    const auto c = static_cast<std::uint32_t>(*text);
    if (c < 0x80) {
      out += static_cast<char>(c);
    } else if (c < 0x800) {
      out += static_cast<char>(0xC0 | (c >> 6));
      out += static_cast<char>(0x80 | (c & 0x3F));
    } else if (c < 0x10000) {
      out += static_cast<char>(0xE0 | (c >> 12));
      out += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (c & 0x3F));
    } else {
      out += static_cast<char>(0xF0 | (c >> 18));
      out += static_cast<char>(0x80 | ((c >> 12) & 0x3F));
      out += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (c & 0x3F));
    }
  }
  return out;
}

std::string hex4(unsigned value) {
  char text[8];
  std::snprintf(text, sizeof text, "%04x", value & 0xFFFFu);
  return text;
}

std::string ids_of(const HidImuProfile& profile) {
  std::string products;
  for (std::size_t i = 0; i < profile.product_ids.size(); ++i) {
    if (i > 0) products += i + 1 == profile.product_ids.size() ? " or " : ", ";
    products += "0x" + hex4(profile.product_ids[i]);
  }
  return "vendor_id 0x" + hex4(profile.vendor_id) + ", product_id " + products;
}

std::string list_devices(const std::vector<HidDeviceInfo>& devices) {
  if (devices.empty()) return "none";
  std::string text;
  for (const auto& d : devices) {
    if (!text.empty()) text += "; ";
    text += hex4(d.vendor_id) + ":" + hex4(d.product_id) + " '" + d.product + "' at " + d.path;
  }
  return text;
}

// The devices the profile matches (`path`, when given, narrows them to that one).
std::vector<HidDeviceInfo> candidates(const std::vector<HidDeviceInfo>& present, const HidImuProfile& profile,
                                      const std::string& path) {
  std::vector<HidDeviceInfo> found;
  for (const auto& device : present) {
    if (profile.matches(device.vendor_id, device.product_id) && (path.empty() || device.path == path)) found.push_back(device);
  }
  return found;
}

class HidapiTransport final : public HidTransport {
 public:
  std::vector<HidDeviceInfo> enumerate() override { return enumerate_hid_devices(); }
  bool open(const std::string& path) override {
    device_.reset();
    if (!hidapi_ready()) return false;
    device_.reset(hid_open_path(path.c_str()));
    return device_ != nullptr;
  }
  int read(std::span<std::uint8_t> buffer, int timeout_ms) override {
    if (!device_) return -1;
    return hid_read_timeout(device_.get(), buffer.data(), buffer.size(), timeout_ms);
  }
  void close() override { device_.reset(); }
  std::string last_error() override { return utf8(hid_error(device_.get())); }

 private:
  DeviceHandle device_;
};

class HidImu final : public ImuSource {
 public:
  HidImu(const HidImuProfile& profile, const HidImuOptions& options, std::unique_ptr<HidTransport> transport,
         const HidDeviceInfo& info)
      : decoder_(profile), options_(options), transport_(std::move(transport)), path_(info.path) {
    description_ = profile.name + " " + hex4(info.vendor_id) + ":" + hex4(info.product_id) + " at " + info.path;
    buffer_.resize(std::max<std::size_t>(profile.report_size, 1) + 1);
    thread_ = std::jthread([this](std::stop_token stop) { run(stop); });
  }
  ~HidImu() override { close(); }
  HidImu(const HidImu&) = delete;
  HidImu& operator=(const HidImu&) = delete;

  std::size_t read(std::vector<ImuSample>& out, double until) override {
    const std::lock_guard lock(queue_mutex_);
    std::size_t count = 0;
    while (!queue_.empty() && queue_.front().timestamp <= until) {
      out.push_back(queue_.front());
      queue_.pop_front();
      ++count;
    }
    return count;
  }
  ImuState state() const override { return state_.load(); }
  Eigen::Quaterniond R_camera_from_imu() const override { return decoder_.profile().R_camera_from_imu; }
  void close() override {
    if (thread_.joinable()) {
      thread_.request_stop();
      wake_.notify_all();
      thread_.join();
    }
    transport_->close();
    state_ = ImuState::Closed;
  }
  std::string describe() const override { return description_; }

 private:
  void run(std::stop_token stop) {
    bool open = true;  // the constructor's caller opened it
    double backoff = options_.reconnect_first;
    const int timeout_ms = std::max(1, static_cast<int>(options_.read_timeout * 1000.0));
    while (!stop.stop_requested()) {
      if (!open) {
        if (reopen()) {
          open = true;
          backoff = options_.reconnect_first;
          decoder_.reset();
          state_ = ImuState::Waiting;
        } else {
          std::unique_lock lock(wake_mutex_);
          wake_.wait_for(lock, stop, std::chrono::duration<double>(backoff), [] { return false; });
          backoff = std::min(2.0 * backoff, options_.reconnect_max);
          continue;
        }
      }
      const int n = transport_->read(buffer_, timeout_ms);
      if (n < 0) {  // unplugged or a device error
        transport_->close();
        open = false;
        state_ = ImuState::Gone;
        continue;
      }
      if (n == 0) continue;
      const double received = steady_seconds();
      ImuSample sample;
      if (decoder_.decode(std::span<const std::uint8_t>(buffer_.data(), static_cast<std::size_t>(n)), received, sample) !=
          DecodeStatus::Ok) {
        continue;  // another report of the device (buttons, status)
      }
      {
        const std::lock_guard lock(queue_mutex_);
        if (queue_.size() >= options_.queue_capacity) queue_.pop_front();
        queue_.push_back(sample);
      }
      state_ = ImuState::Streaming;
    }
  }

  // The same device when it comes back (its path may change: then the first that matches).
  bool reopen() {
    auto found = candidates(transport_->enumerate(), decoder_.profile(), options_.path);
    std::stable_partition(found.begin(), found.end(), [&](const HidDeviceInfo& d) { return d.path == path_; });
    for (const auto& device : found) {
      if (transport_->open(device.path)) {
        path_ = device.path;
        return true;
      }
    }
    return false;
  }

  HidReportDecoder decoder_;
  HidImuOptions options_;
  std::unique_ptr<HidTransport> transport_;  // the reading thread's once it runs
  std::string path_;
  std::string description_;
  std::vector<std::uint8_t> buffer_;
  std::atomic<ImuState> state_{ImuState::Waiting};
  std::mutex queue_mutex_;
  std::deque<ImuSample> queue_;
  std::mutex wake_mutex_;
  std::condition_variable_any wake_;
  std::jthread thread_;  // last: it starts after everything it uses
};

}  // namespace

std::vector<HidDeviceInfo> enumerate_hid_devices(std::span<const HidImuProfile> profiles) {
  std::vector<HidDeviceInfo> devices;
  if (!hidapi_ready()) return devices;
  const std::unique_ptr<hid_device_info, EnumerationFree> list(hid_enumerate(0, 0));
  for (const hid_device_info* d = list.get(); d != nullptr; d = d->next) {
    HidDeviceInfo info;
    info.vendor_id = d->vendor_id;
    info.product_id = d->product_id;
    info.path = d->path ? d->path : "";
    info.manufacturer = utf8(d->manufacturer_string);
    info.product = utf8(d->product_string);
    info.serial = utf8(d->serial_number);
    info.interface_number = d->interface_number;
    for (const auto& profile : profiles) {
      if (profile.matches(info.vendor_id, info.product_id)) {
        info.profile = profile.name;
        info.profile_file = profile.file;
        break;
      }
    }
    devices.push_back(std::move(info));
  }
  return devices;
}

std::unique_ptr<HidTransport> hidapi_transport() { return std::make_unique<HidapiTransport>(); }

std::unique_ptr<ImuSource> open_hid_imu(const HidImuProfile& profile, const HidImuOptions& options) {
  if (!hidapi_ready()) {
    throw InputError(input_message(profile.file, -1, -1, "", "hidapi cannot start on this system",
                                   "check that /dev/hidraw* exists (the hidraw kernel module) and is readable"));
  }
  return open_hid_imu(profile, options, hidapi_transport());
}

std::unique_ptr<ImuSource> open_hid_imu(const HidImuProfile& profile, const HidImuOptions& options,
                                        std::unique_ptr<HidTransport> transport) {
  const std::vector<HidDeviceInfo> present = transport->enumerate();
  const auto found = candidates(present, profile, options.path);
  if (found.empty()) {
    const std::string what = options.path.empty() ? "no HID device matches " + ids_of(profile)
                                                   : "no HID device with " + ids_of(profile) + " is at " + options.path;
    throw InputError(input_message(profile.file, -1, -1, "vendor_id", what + " (HID devices present: " + list_devices(present) + ")",
                                   "plug the IMU in (over USB: Bluetooth reports have another layout), or correct "
                                   "vendor_id and product_id from 'skylit-calib hid list'"));
  }
  std::string errors;
  for (const auto& device : found) {
    if (transport->open(device.path)) return std::make_unique<HidImu>(profile, options, std::move(transport), device);
    errors += (errors.empty() ? "" : "; ") + device.path + ": " + transport->last_error();
  }
  throw InputError(input_message(profile.file, -1, -1, "", "the device cannot be opened (" + errors + ")",
                                 "give the user read/write access to the device: add a udev rule (docs/imu.md), "
                                 "then unplug and plug it again"));
}

}  // namespace skylit::track
