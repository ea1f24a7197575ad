// libcamera cameras: enumerate, configure one stream, a request loop over mmap'd frame buffers,
// ExposureTime and AnalogueGain per request. Written against Debian 12's libcamera 0.0.3.
#include "skylit/capture/libcamera_source.hpp"

#include <sys/mman.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>

#include <libcamera/libcamera.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "skylit/base/error.hpp"

namespace skylit::capture {
namespace {

namespace lc = libcamera;

// libcamera allows one CameraManager per process (a second one aborts the program), so every
// source and every listing shares one, kept alive while any of them holds it.
std::shared_ptr<lc::CameraManager> camera_manager() {
  static std::mutex mutex;
  static std::weak_ptr<lc::CameraManager> shared;
  const std::lock_guard lock(mutex);
  if (auto manager = shared.lock()) return manager;
  auto created = std::make_unique<lc::CameraManager>();
  if (const int error = created->start(); error != 0) {
    throw CaptureError(std::string("libcamera: the camera manager did not start: ") + std::strerror(-error));
  }
  std::shared_ptr<lc::CameraManager> manager(created.release(), [](lc::CameraManager* started) {
    started->stop();
    delete started;
  });
  shared = manager;
  return manager;
}

std::string camera_model(const lc::Camera& camera) {
  return camera.properties().get(lc::properties::Model).value_or(std::string());
}

bool is_camera_index(const std::string& text) {
  return !text.empty() && std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
}

// A read-only mapping of a dmabuf, unmapped with its owner.
class Mapping {
 public:
  Mapping(int fd, std::size_t length) : length_(length) {
    void* address = ::mmap(nullptr, length, PROT_READ, MAP_SHARED, fd, 0);
    if (address == MAP_FAILED) throw CaptureError(std::string("libcamera: cannot map a frame buffer: ") + std::strerror(errno));
    address_ = static_cast<unsigned char*>(address);
  }
  ~Mapping() { ::munmap(address_, length_); }
  Mapping(const Mapping&) = delete;
  Mapping& operator=(const Mapping&) = delete;
  const unsigned char* data() const { return address_; }

 private:
  unsigned char* address_ = nullptr;
  std::size_t length_ = 0;
};

}  // namespace

// ---------------------------------------------------------------------------------------------
// Pixel formats.

const std::vector<std::string>& libcamera_pixel_formats() {
  static const std::vector<std::string> formats{"RGB888", "BGR888", "XRGB8888", "XBGR8888", "YUYV", "NV12", "MJPEG"};
  return formats;
}

cv::Mat libcamera_frame_to_bgr(const std::string& pixel_format, cv::Size size, int stride,
                               std::span<const std::span<const unsigned char>> planes, std::size_t used) {
  const int w = size.width;
  const int h = size.height;
  if (planes.empty() || w <= 0 || h <= 0 || stride <= 0) return {};
  const auto& first = planes[0];
  const auto rows_fit = [&](std::span<const unsigned char> plane, int rows, int row_bytes) {
    return rows > 0 && plane.size() >= static_cast<std::size_t>(stride) * static_cast<std::size_t>(rows - 1) +
                                           static_cast<std::size_t>(row_bytes);
  };
  // libcamera names formats as DRM does, little-endian: RGB888 is stored B, G, R in memory.
  auto* data = const_cast<unsigned char*>(first.data());  // wrapped read-only, then copied
  cv::Mat bgr;
  if (pixel_format == "RGB888" || pixel_format == "BGR888") {
    if (!rows_fit(first, h, 3 * w)) return {};
    const cv::Mat view(h, w, CV_8UC3, data, static_cast<std::size_t>(stride));
    if (pixel_format == "RGB888") {
      bgr = view.clone();
    } else {
      cv::cvtColor(view, bgr, cv::COLOR_RGB2BGR);
    }
  } else if (pixel_format == "XRGB8888" || pixel_format == "XBGR8888") {
    if (!rows_fit(first, h, 4 * w)) return {};
    const cv::Mat view(h, w, CV_8UC4, data, static_cast<std::size_t>(stride));
    cv::cvtColor(view, bgr, pixel_format == "XRGB8888" ? cv::COLOR_BGRA2BGR : cv::COLOR_RGBA2BGR);
  } else if (pixel_format == "YUYV") {
    if (!rows_fit(first, h, 2 * w)) return {};
    const cv::Mat view(h, w, CV_8UC2, data, static_cast<std::size_t>(stride));
    cv::cvtColor(view, bgr, cv::COLOR_YUV2BGR_YUYV);
  } else if (pixel_format == "NV12") {
    if (w % 2 != 0 || h % 2 != 0) return {};
    // Luma rows, then interleaved chroma rows, in one plane or two.
    std::span<const unsigned char> chroma;
    if (planes.size() >= 2) {
      chroma = planes[1];
    } else if (first.size() > static_cast<std::size_t>(stride) * static_cast<std::size_t>(h)) {
      chroma = first.subspan(static_cast<std::size_t>(stride) * static_cast<std::size_t>(h));
    }
    if (!rows_fit(first, h, w) || !rows_fit(chroma, h / 2, w)) return {};
    cv::Mat packed(h + h / 2, w, CV_8UC1);
    for (int y = 0; y < h; ++y) {
      std::memcpy(packed.ptr(y), first.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(stride),
                  static_cast<std::size_t>(w));
    }
    for (int y = 0; y < h / 2; ++y) {
      std::memcpy(packed.ptr(h + y), chroma.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(stride),
                  static_cast<std::size_t>(w));
    }
    cv::cvtColor(packed, bgr, cv::COLOR_YUV2BGR_NV12);
  } else if (pixel_format == "MJPEG") {
    const std::size_t bytes = std::min(used, first.size());
    if (bytes == 0) return {};
    const cv::Mat encoded(1, static_cast<int>(bytes), CV_8UC1, data);
    bgr = cv::imdecode(encoded, cv::IMREAD_COLOR);
  }
  return bgr;
}

// ---------------------------------------------------------------------------------------------
// Enumeration.

std::vector<LibcameraCamera> list_libcamera_cameras() {
  const auto manager = camera_manager();
  std::vector<LibcameraCamera> cameras;
  for (const auto& camera : manager->cameras()) cameras.push_back({camera->id(), camera_model(*camera)});
  return cameras;
}

std::string describe_cameras(const std::vector<LibcameraCamera>& cameras) {
  if (cameras.empty()) return "none found";
  std::string text;
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    if (!text.empty()) text += ", ";
    text += std::to_string(i) + ": " + (cameras[i].model.empty() ? cameras[i].id : cameras[i].model + " (" + cameras[i].id + ")");
  }
  return text;
}

// ---------------------------------------------------------------------------------------------
// The source.

struct LibcameraSource::Impl {
  struct Plane {
    const unsigned char* data = nullptr;
    std::size_t length = 0;
  };

  LibcameraSettings settings;
  std::shared_ptr<lc::CameraManager> manager;
  std::shared_ptr<lc::Camera> camera;
  bool acquired = false;
  bool started = false;
  bool connected = false;
  std::unique_ptr<lc::CameraConfiguration> configuration;
  lc::Stream* stream = nullptr;
  std::string format;
  cv::Size size;
  int stride = 0;
  std::unique_ptr<lc::FrameBufferAllocator> allocator;
  std::vector<std::unique_ptr<Mapping>> mappings;
  std::map<const lc::FrameBuffer*, std::vector<Plane>> planes;
  std::vector<std::unique_ptr<lc::Request>> requests;
  bool has_exposure = false;
  bool has_gain = false;
  bool has_auto_exposure = false;
  std::optional<double> exposure_time;  // guarded by `mutex` once the camera runs

  std::optional<double> gain;
  std::string description;

  // Filled by libcamera's thread, emptied by the reader.
  std::mutex mutex;
  std::condition_variable completed_changed;
  std::deque<lc::Request*> completed;
  bool disconnected = false;

  ~Impl() {
    if (started) camera->stop();  // completes every queued request as cancelled
    if (connected) {
      camera->requestCompleted.disconnect(this);
      camera->disconnected.disconnect(this);
    }
    requests.clear();
    planes.clear();
    mappings.clear();
    allocator.reset();
    if (acquired) camera->release();
  }

  void request_completed(lc::Request* request) {
    if (request->status() == lc::Request::RequestCancelled) return;
    {
      const std::lock_guard lock(mutex);
      completed.push_back(request);
    }
    completed_changed.notify_all();
  }

  void camera_disconnected() {
    {
      const std::lock_guard lock(mutex);
      disconnected = true;
    }
    completed_changed.notify_all();
  }

  void apply_controls(lc::Request& request) {
    std::optional<double> time;
    std::optional<double> analogue;
    {
      const std::lock_guard lock(mutex);
      time = exposure_time;
      analogue = gain;
    }
    // Manual exposure while either is set; back to automatic when neither is (after a bracket).
    if (has_auto_exposure) request.controls().set(lc::controls::AeEnable, !time && !analogue);
    if (time) request.controls().set(lc::controls::ExposureTime, static_cast<std::int32_t>(std::lround(*time * 1e6)));
    if (analogue) request.controls().set(lc::controls::AnalogueGain, static_cast<float>(*analogue));
  }

  void queue(lc::Request& request) {
    apply_controls(request);
    if (const int error = camera->queueRequest(&request); error < 0) {
      throw CaptureError(description + ": a request was refused: " + std::strerror(-error));
    }
  }

  // The next completed request, or nullptr at the deadline.
  lc::Request* wait(std::chrono::steady_clock::time_point deadline) {
    std::unique_lock lock(mutex);
    completed_changed.wait_until(lock, deadline, [this] { return disconnected || !completed.empty(); });
    if (disconnected) throw CaptureError(description + ": the camera was disconnected");
    if (completed.empty()) return nullptr;
    lc::Request* request = completed.front();
    completed.pop_front();
    return request;
  }

  // The request's frame (an empty image when it failed or does not decode), then the request
  // goes back to the camera.
  Frame take(lc::Request& request) {
    Frame frame;
    const lc::FrameBuffer* buffer = request.findBuffer(stream);
    if (buffer != nullptr && buffer->metadata().status == lc::FrameMetadata::FrameSuccess) {
      const lc::FrameMetadata& metadata = buffer->metadata();
      std::vector<std::span<const unsigned char>> views;
      for (const Plane& plane : planes.at(buffer)) views.emplace_back(plane.data, plane.length);
      const std::size_t used = metadata.planes().empty() ? 0 : metadata.planes()[0].bytesused;
      frame.image = libcamera_frame_to_bgr(format, size, stride, views, used);
      frame.timestamp = static_cast<double>(metadata.timestamp) * 1e-9;
      frame.utc = std::chrono::floor<std::chrono::seconds>(std::chrono::system_clock::now());  // a live camera's frame is now
      frame.sequence = metadata.sequence;
      if (const auto exposure = request.metadata().get(lc::controls::ExposureTime)) frame.exposure_time = *exposure * 1e-6;
      if (const auto analogue = request.metadata().get(lc::controls::AnalogueGain)) frame.gain = *analogue;
    }
    request.reuse(lc::Request::ReuseBuffers);
    queue(request);
    return frame;
  }
};

LibcameraSource::LibcameraSource(const LibcameraSettings& settings, FrameChecks checks)
    : FrameSource(checks), impl_(std::make_unique<Impl>()) {
  Impl& d = *impl_;
  d.settings = settings;
  const auto& formats = libcamera_pixel_formats();
  if (std::find(formats.begin(), formats.end(), settings.pixel_format) == formats.end()) {
    std::string list;
    for (const auto& f : formats) list += (list.empty() ? "" : ", ") + f;
    throw InputError(input_message("", -1, -1, "pixel_format", "'" + settings.pixel_format + "' is not supported",
                                   "use one of " + list));
  }
  if (settings.buffer_count < 1 || settings.buffer_count > 32) {
    throw InputError(input_message("", -1, -1, "buffer_count", "got " + std::to_string(settings.buffer_count),
                                   "use 2 to 8 requests in flight (4 is the default)"));
  }
  d.manager = camera_manager();
  const auto cameras = d.manager->cameras();
  if (settings.camera.empty()) {
    if (!cameras.empty()) d.camera = cameras.front();
  } else if (is_camera_index(settings.camera)) {
    const auto index = std::stoul(settings.camera);
    if (index < cameras.size()) d.camera = cameras[index];
  } else {
    d.camera = d.manager->get(settings.camera);
    for (const auto& camera : cameras) {
      if (!d.camera && camera_model(*camera) == settings.camera) d.camera = camera;
    }
  }
  if (!d.camera) {
    throw InputError(input_message(
        "", -1, -1, "camera",
        "no libcamera camera '" + (settings.camera.empty() ? std::string("(the first)") : settings.camera) +
            "'; cameras present: " + describe_cameras(list_libcamera_cameras()),
        "connect the camera (and enable it: dtoverlay on a Raspberry Pi), or give one of the cameras present by "
        "index, id or model"));
  }
  const std::string model = camera_model(*d.camera);
  d.description = "libcamera " + (model.empty() ? d.camera->id() : model + " (" + d.camera->id() + ")");

  if (d.camera->acquire() < 0) {
    throw CaptureError(d.description + ": cannot acquire the camera (another program uses it?)");
  }
  d.acquired = true;

  d.configuration = d.camera->generateConfiguration({lc::StreamRole::Viewfinder});
  if (!d.configuration || d.configuration->empty()) throw CaptureError(d.description + ": no stream configuration");
  lc::StreamConfiguration& stream_config = d.configuration->at(0);
  stream_config.pixelFormat = lc::PixelFormat::fromString(settings.pixel_format);
  if (settings.width > 0 && settings.height > 0) {
    stream_config.size = lc::Size(static_cast<unsigned>(settings.width), static_cast<unsigned>(settings.height));
  }
  stream_config.bufferCount = static_cast<unsigned>(settings.buffer_count);
  const auto status = d.configuration->validate();
  if (status == lc::CameraConfiguration::Invalid) throw CaptureError(d.description + ": the configuration is invalid");
  if (stream_config.pixelFormat.toString() != settings.pixel_format) {
    std::string offered;
    for (const auto& f : stream_config.formats().pixelformats()) offered += (offered.empty() ? "" : ", ") + f.toString();
    throw InputError(input_message("", -1, -1, "pixel_format",
                                   d.description + " cannot deliver " + settings.pixel_format + " (it offers " +
                                       offered + ")",
                                   "choose one it offers that skylit reads"));
  }
  if (d.camera->configure(d.configuration.get()) < 0) throw CaptureError(d.description + ": configure failed");
  d.stream = stream_config.stream();
  d.format = settings.pixel_format;
  d.size = cv::Size(static_cast<int>(stream_config.size.width), static_cast<int>(stream_config.size.height));
  d.stride = static_cast<int>(stream_config.stride);

  const lc::ControlInfoMap& controls = d.camera->controls();
  d.has_exposure = controls.count(lc::controls::ExposureTime.id()) > 0;
  d.has_gain = controls.count(lc::controls::AnalogueGain.id()) > 0;
  d.has_auto_exposure = controls.count(lc::controls::AeEnable.id()) > 0;
  if (settings.exposure_time && d.has_exposure) d.exposure_time = settings.exposure_time;
  if (settings.gain && d.has_gain) d.gain = settings.gain;

  d.allocator = std::make_unique<lc::FrameBufferAllocator>(d.camera);
  if (d.allocator->allocate(d.stream) < 0) throw CaptureError(d.description + ": cannot allocate frame buffers");
  for (const auto& buffer : d.allocator->buffers(d.stream)) {
    // Planes may share one dmabuf at different offsets: map each buffer once, whole.
    std::map<int, std::size_t> extent;
    for (const auto& plane : buffer->planes()) {
      auto& end = extent[plane.fd.get()];
      end = std::max(end, static_cast<std::size_t>(plane.offset) + plane.length);
    }
    std::map<int, const Mapping*> mapped;
    for (const auto& [fd, length] : extent) {
      d.mappings.push_back(std::make_unique<Mapping>(fd, length));
      mapped[fd] = d.mappings.back().get();
    }
    auto& views = d.planes[buffer.get()];
    for (const auto& plane : buffer->planes()) views.push_back({mapped[plane.fd.get()]->data() + plane.offset, plane.length});

    std::unique_ptr<lc::Request> request = d.camera->createRequest();
    if (!request || request->addBuffer(d.stream, buffer.get()) < 0) {
      throw CaptureError(d.description + ": cannot attach a buffer to a request");
    }
    d.requests.push_back(std::move(request));
  }

  d.camera->requestCompleted.connect(impl_.get(), &Impl::request_completed);
  d.camera->disconnected.connect(impl_.get(), &Impl::camera_disconnected);
  d.connected = true;
  if (d.camera->start() < 0) throw CaptureError(d.description + ": the camera did not start");
  d.started = true;
  for (const auto& request : d.requests) d.queue(*request);
}

LibcameraSource::~LibcameraSource() = default;

std::string LibcameraSource::describe() const { return impl_->description; }

bool LibcameraSource::set_exposure_time(double seconds) {
  if (!impl_->has_exposure || !(seconds > 0) || !std::isfinite(seconds)) return false;
  const std::lock_guard lock(impl_->mutex);
  impl_->exposure_time = seconds;
  return true;
}

bool LibcameraSource::set_gain(double gain) {
  if (!impl_->has_gain || !(gain > 0) || !std::isfinite(gain)) return false;
  const std::lock_guard lock(impl_->mutex);
  impl_->gain = gain;
  return true;
}

FrameResult LibcameraSource::read(double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                              std::chrono::duration<double>(std::max(0.0, timeout_s)));
  while (lc::Request* request = impl_->wait(deadline)) {
    Frame frame = impl_->take(*request);
    if (!frame.image.empty()) return {FrameStatus::Ready, std::move(frame)};
    count_unreadable();  // a failed capture or a corrupt MJPEG frame
  }
  return {FrameStatus::NotYet, {}};
}

std::optional<std::vector<Frame>> LibcameraSource::read_bracket(std::span<const double> exposure_times_s,
                                                                double timeout_s) {
  if (!impl_->has_exposure) return std::nullopt;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                              std::chrono::duration<double>(std::max(0.0, timeout_s)));
  std::optional<double> before;
  {
    const std::lock_guard lock(impl_->mutex);
    before = impl_->exposure_time;
  }
  std::vector<Frame> frames;
  for (const double exposure : exposure_times_s) {
    if (!set_exposure_time(exposure)) continue;
    std::optional<Frame> last;
    // Requests already queued carry the old exposure: wait for them to drain, then for the
    // sensor to apply the new one.
    const int tries = impl_->settings.buffer_count + impl_->settings.bracket_settle_frames;
    for (int k = 0; k < tries; ++k) {
      lc::Request* request = impl_->wait(deadline);
      if (request == nullptr) break;
      Frame frame = impl_->take(*request);
      if (frame.image.empty()) {
        count_unreadable();
        continue;
      }
      const bool reached = frame.exposure_time &&
                           std::abs(*frame.exposure_time - exposure) <= std::max(0.02 * exposure, 20e-6);
      last = std::move(frame);
      if (reached) break;
    }
    if (last) frames.push_back(std::move(*last));
  }
  {
    const std::lock_guard lock(impl_->mutex);
    impl_->exposure_time = before;
  }
  return frames;
}

}  // namespace skylit::capture
