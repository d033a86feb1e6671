#include "ips/drivers/gige_camera.hpp"

#include <arv.h>

#include <cmath>
#include <cstring>
#include <stdexcept>

#include "ips/config.hpp"
#include "ips/drivers/common_clock.hpp"
#include "ips/log.hpp"

namespace ips::drivers {

GigeCameraSettings GigeCameraSettings::fromConfig(const Config& c) {
  GigeCameraSettings s;
  s.id = c.getString("id", s.id);
  s.pixel_format = c.getString("pixel_format", s.pixel_format);
  s.width = c.getInt("width", s.width);
  s.height = c.getInt("height", s.height);
  s.offset_x = c.getInt("offset_x", s.offset_x);
  s.offset_y = c.getInt("offset_y", s.offset_y);
  s.exposure_us = c.getDouble("exposure_us", s.exposure_us);
  s.gain_db = c.getDouble("gain_db", s.gain_db);
  s.frame_rate_hz = c.getDouble("frame_rate_hz", s.frame_rate_hz);
  s.trigger_source = c.getString("trigger_source", s.trigger_source);
  s.packet_size = c.getInt("packet_size", s.packet_size);
  s.packet_delay_ns = c.getInt("packet_delay_ns", static_cast<int>(s.packet_delay_ns));
  s.packet_resend = c.getBool("packet_resend", s.packet_resend);
  s.packet_timeout_ms = c.getInt("packet_timeout_ms", s.packet_timeout_ms);
  s.frame_retention_ms = c.getInt("frame_retention_ms", s.frame_retention_ms);
  s.buffers = c.getInt("buffers", s.buffers);
  s.packet_socket = c.getBool("packet_socket", s.packet_socket);
  s.reconnect_after_s = c.getDouble("reconnect_after_s", s.reconnect_after_s);
  s.retry_interval_s = c.getDouble("retry_interval_s", s.retry_interval_s);
  if (s.buffers < 2) throw ConfigError(c.path() + ": buffers must be >= 2");
  if (!(s.reconnect_after_s > 0) || !(s.retry_interval_s > 0))
    throw ConfigError(c.path() + ": reconnect_after_s and retry_interval_s must be > 0");
  return s;
}

struct GigeCamera::Impl {
  ArvCamera* camera = nullptr;
  ArvStream* stream = nullptr;
  gulong control_lost_handler = 0;
  std::atomic<bool> control_lost{false};
  int bytes_per_pixel = 1;
  float exposure_us = 0, gain_db = 0;
  guint64 resent_base = 0, missing_base = 0, underrun_base = 0;

  static void onControlLost(ArvDevice*, gpointer self) { static_cast<Impl*>(self)->control_lost = true; }

  void close() {
    if (stream) {
      g_object_unref(stream);
      stream = nullptr;
    }
    if (camera) {
      ArvDevice* device = arv_camera_get_device(camera);
      if (control_lost_handler && device) g_signal_handler_disconnect(device, control_lost_handler);
      control_lost_handler = 0;
      g_object_unref(camera);
      camera = nullptr;
    }
    control_lost = false;
  }
};

namespace {

class GErrorCheck {
 public:
  explicit GErrorCheck(std::string who) : who_(std::move(who)) {}
  GError** operator&() { return &error_; }
  void check(const std::string& what) {
    if (!error_) return;
    const std::string message = error_->message ? error_->message : "unknown error";
    g_clear_error(&error_);
    throw std::runtime_error("camera " + who_ + ": " + what + ": " + message);
  }
  ~GErrorCheck() { g_clear_error(&error_); }

 private:
  std::string who_;
  GError* error_ = nullptr;
};

const char* statusName(ArvBufferStatus s) {
  switch (s) {
    case ARV_BUFFER_STATUS_SUCCESS:
      return "success";
    case ARV_BUFFER_STATUS_CLEARED:
      return "cleared";
    case ARV_BUFFER_STATUS_TIMEOUT:
      return "timeout";
    case ARV_BUFFER_STATUS_MISSING_PACKETS:
      return "missing_packets";
    case ARV_BUFFER_STATUS_WRONG_PACKET_ID:
      return "wrong_packet_id";
    case ARV_BUFFER_STATUS_SIZE_MISMATCH:
      return "size_mismatch";
    case ARV_BUFFER_STATUS_FILLING:
      return "filling";
    case ARV_BUFFER_STATUS_ABORTED:
      return "aborted";
    default:
      return "other";
  }
}

// Finds the Aravis device id of the camera with this serial number, id or address ("" if not found).
std::string findDevice(const std::string& wanted, std::string* seen) {
  arv_update_device_list();
  const unsigned n = arv_get_n_devices();
  for (unsigned i = 0; i < n; ++i) {
    const char* id = arv_get_device_id(i);
    const char* serial = arv_get_device_serial_nbr(i);
    const char* address = arv_get_device_address(i);
    if (seen)
      *seen += std::string(seen->empty() ? "" : ", ") + (id ? id : "?") + " (" + (address ? address : "?") + ")";
    if ((id && wanted == id) || (serial && wanted == serial) || (address && wanted == address)) return id ? id : "";
  }
  return "";
}

}  // namespace

GigeCamera::GigeCamera(GigeCameraSettings settings) : settings_(std::move(settings)), impl_(std::make_unique<Impl>()) {
  if (settings_.id.empty()) throw std::invalid_argument("GigeCamera: no camera id (serial number or address) given");
  serial_ = settings_.id;
  for (const char* name : {"frames", "lost", "reconnects", "connect_failures", "resent_packets", "missing_packets",
                           "underruns", "not_an_image", "bad_image_size"})
    counters_[name] = 0;
}

GigeCamera::~GigeCamera() { disconnect(); }

bool GigeCamera::connected() const { return connected_; }

void GigeCamera::closeCamera() {
  if (!impl_->camera) return;
  GError* error = nullptr;
  arv_camera_stop_acquisition(impl_->camera, &error);  // fails (after GVCP timeouts) when the camera is gone
  g_clear_error(&error);
  impl_->close();
}

void GigeCamera::disconnect() {
  if (connector_.joinable()) connector_.join();
  if (connected_) harvestStatistics();
  connected_ = false;
  pending_close_ = false;
  closeCamera();
}

void GigeCamera::harvestStatistics() {
  if (!impl_->stream) return;
  guint64 completed = 0, failures = 0, underruns = 0;
  arv_stream_get_statistics(impl_->stream, &completed, &failures, &underruns);
  counters_["underruns"] += static_cast<int64_t>(underruns - impl_->underrun_base);
  impl_->underrun_base = underruns;
  if (ARV_IS_GV_STREAM(impl_->stream)) {
    guint64 resent = 0, missing = 0;
    arv_gv_stream_get_statistics(ARV_GV_STREAM(impl_->stream), &resent, &missing);
    counters_["resent_packets"] += static_cast<int64_t>(resent - impl_->resent_base);
    counters_["missing_packets"] += static_cast<int64_t>(missing - impl_->missing_base);
    impl_->resent_base = resent;
    impl_->missing_base = missing;
  }
}

void GigeCamera::connect() {
  const GigeCameraSettings& s = settings_;
  std::string seen;
  // An IPv4 address is opened directly; a serial number or device id needs discovery (which takes a while).
  GInetAddress* as_address = g_inet_address_new_from_string(s.id.c_str());
  const bool is_address = as_address != nullptr;
  if (as_address) g_object_unref(as_address);
  const std::string device_id = is_address ? "" : findDevice(s.id, &seen);
  GErrorCheck err(s.id);
  // Not discovered (a camera on a routed network, or discovery blocked): an address is opened directly.
  ArvCamera* camera = arv_camera_new(device_id.empty() ? s.id.c_str() : device_id.c_str(), &err);
  if (!camera) {
    try {
      err.check("cannot open");
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(std::string(e.what()) + " (cameras seen: " + (seen.empty() ? "none" : seen) + ")");
    }
    throw std::runtime_error("camera " + s.id + ": cannot open (cameras seen: " + (seen.empty() ? "none" : seen) + ")");
  }
  impl_->camera = camera;
  try {
    const char* serial = arv_camera_get_device_serial_number(camera, &err);
    err.check("read serial number");
    serial_ = serial ? serial : s.id;
    if (arv_camera_is_gv_device(camera)) {
      arv_camera_gv_set_stream_options(
          camera, s.packet_socket ? ARV_GV_STREAM_OPTION_NONE : ARV_GV_STREAM_OPTION_PACKET_SOCKET_DISABLED);
      if (s.packet_size > 0) {
        arv_camera_gv_set_packet_size(camera, s.packet_size, &err);
        err.check("set packet size " + std::to_string(s.packet_size));
      } else {
        arv_camera_gv_auto_packet_size(camera, &err);
        err.check("negotiate packet size");
      }
      if (s.packet_delay_ns > 0) {
        arv_camera_gv_set_packet_delay(camera, s.packet_delay_ns, &err);
        err.check("set packet delay");
      }
    }
    arv_camera_set_pixel_format_from_string(camera, s.pixel_format.c_str(), &err);
    err.check("set pixel format " + s.pixel_format);
    if (s.pixel_format == "Mono8")
      impl_->bytes_per_pixel = 1;
    else if (s.pixel_format == "Mono10" || s.pixel_format == "Mono12" || s.pixel_format == "Mono16")
      impl_->bytes_per_pixel = 2;
    else
      throw std::runtime_error("camera " + s.id + ": pixel format " + s.pixel_format +
                               " not supported (Mono8, Mono10, Mono12, Mono16)");
    if (s.width > 0 && s.height > 0) {
      arv_camera_set_region(camera, s.offset_x, s.offset_y, s.width, s.height, &err);
      err.check("set region " + std::to_string(s.width) + "x" + std::to_string(s.height));
    }
    if (s.trigger_source.empty()) {
      arv_camera_clear_triggers(camera, &err);
      err.check("switch triggers off");
      if (s.frame_rate_hz > 0) {
        arv_camera_set_frame_rate(camera, s.frame_rate_hz, &err);
        err.check("set frame rate");
      }
    } else {
      arv_camera_set_trigger(camera, s.trigger_source.c_str(), &err);
      err.check("set trigger source " + s.trigger_source);
    }
    if (s.exposure_us > 0) {
      arv_camera_set_exposure_time(camera, s.exposure_us, &err);
      err.check("set exposure");
    }
    if (s.gain_db >= 0) {
      arv_camera_set_gain(camera, s.gain_db, &err);
      err.check("set gain");
    }
    impl_->exposure_us = static_cast<float>(arv_camera_get_exposure_time(camera, &err));
    err.check("read exposure");
    impl_->gain_db = static_cast<float>(arv_camera_get_gain(camera, &err));
    err.check("read gain");

    const guint payload = arv_camera_get_payload(camera, &err);
    err.check("read payload size");
    impl_->stream = arv_camera_create_stream(camera, nullptr, nullptr, &err);
    err.check("create stream");
    if (!impl_->stream) throw std::runtime_error("camera " + s.id + ": no stream");
    if (ARV_IS_GV_STREAM(impl_->stream)) {
      g_object_set(impl_->stream, "packet-resend",
                   s.packet_resend ? ARV_GV_STREAM_PACKET_RESEND_ALWAYS : ARV_GV_STREAM_PACKET_RESEND_NEVER,
                   "packet-timeout", static_cast<guint>(s.packet_timeout_ms * 1000), "frame-retention",
                   static_cast<guint>(s.frame_retention_ms * 1000), nullptr);
    }
    impl_->resent_base = impl_->missing_base = impl_->underrun_base = 0;
    for (int i = 0; i < s.buffers; ++i) arv_stream_push_buffer(impl_->stream, arv_buffer_new(payload, nullptr));
    impl_->control_lost = false;
    impl_->control_lost_handler =
        g_signal_connect(arv_camera_get_device(camera), "control-lost", G_CALLBACK(&Impl::onControlLost), impl_.get());
    arv_camera_set_acquisition_mode(camera, ARV_ACQUISITION_MODE_CONTINUOUS, &err);
    err.check("set continuous acquisition");
    arv_camera_start_acquisition(camera, &err);
    err.check("start acquisition");
  } catch (...) {
    impl_->close();
    throw;
  }
}

bool GigeCamera::ensureConnected() {
  if (connected_) return true;
  if (connector_.joinable()) {
    if (!connect_done_) return false;  // still connecting
    connector_.join();
    if (!connect_error_.empty()) {
      count("connect_failures");
      if (connect_error_ != last_error_) IPS_WARN(connect_error_ << "; retrying");
      last_error_ = connect_error_;
      return false;
    }
    last_error_.clear();
    if (configured_once_) count("reconnects");
    configured_once_ = true;
    connected_ = true;
    ++connections_;
    last_frame_us_ = last_grab_us_ = commonClockNowUs();
    IPS_INFO("camera " << serial_ << " acquiring (" << settings_.pixel_format << ", exposure " << impl_->exposure_us
                       << " us, gain " << impl_->gain_db << " dB)");
    return true;
  }
  const int64_t now = commonClockNowUs();
  if (now - last_attempt_us_ < static_cast<int64_t>(settings_.retry_interval_s * 1e6)) return false;
  last_attempt_us_ = now;
  connect_done_ = false;
  connect_error_.clear();
  const bool close_first = pending_close_;
  pending_close_ = false;
  connector_ = std::thread([this, close_first] {
    // Closing a camera that went away waits for GVCP timeouts: done here, not in the caller's loop.
    if (close_first) closeCamera();
    try {
      connect();
    } catch (const std::exception& e) {
      connect_error_ = e.what();
    }
    connect_done_ = true;
  });
  return false;
}

std::optional<CameraFrame> GigeCamera::grab(int timeout_ms) {
  if (!connected_) return std::nullopt;
  const int64_t now = commonClockNowUs();
  // Time in which nobody waited for frames (the other camera was connecting) does not count as silence.
  if (now - last_grab_us_ > 200'000) last_frame_us_ += now - last_grab_us_;
  last_grab_us_ = now;
  if (impl_->control_lost || now - last_frame_us_ > static_cast<int64_t>(settings_.reconnect_after_s * 1e6)) {
    IPS_WARN("camera " << serial_ << (impl_->control_lost ? ": control lost" : ": no frames") << "; reconnecting");
    count("lost");
    harvestStatistics();
    connected_ = false;
    pending_close_ = true;  // closed by the next connection attempt, in the background
    return std::nullopt;
  }
  ArvBuffer* buffer = arv_stream_timeout_pop_buffer(impl_->stream, static_cast<guint64>(timeout_ms) * 1000);
  if (!buffer) {
    return std::nullopt;
  }
  std::optional<CameraFrame> frame;
  const ArvBufferStatus status = arv_buffer_get_status(buffer);
  if (status != ARV_BUFFER_STATUS_SUCCESS) {
    count(std::string("incomplete_") + statusName(status));
  } else if (arv_buffer_get_payload_type(buffer) != ARV_BUFFER_PAYLOAD_TYPE_IMAGE) {
    count("not_an_image");
  } else {
    size_t size = 0;
    const void* data = arv_buffer_get_image_data(buffer, &size);
    CameraFrame f;
    f.width = arv_buffer_get_image_width(buffer);
    f.height = arv_buffer_get_image_height(buffer);
    f.bytes_per_pixel = impl_->bytes_per_pixel;
    f.stride = f.width * f.bytes_per_pixel;
    if (!data || f.width <= 0 || f.height <= 0 || size < static_cast<size_t>(f.stride) * f.height) {
      count("bad_image_size");
    } else {
      f.device_time_ns = static_cast<int64_t>(arv_buffer_get_timestamp(buffer));
      const guint64 system_ns = arv_buffer_get_system_timestamp(buffer);
      f.arrival_us = system_ns ? static_cast<int64_t>(system_ns / 1000) : now;
      f.frame_id = arv_buffer_get_frame_id(buffer);
      f.exposure_us = impl_->exposure_us;
      f.gain_db = impl_->gain_db;
      const uint8_t* bytes = static_cast<const uint8_t*>(data);
      f.data.assign(bytes, bytes + static_cast<size_t>(f.stride) * f.height);
      count("frames");
      last_frame_us_ = now;
      frame = std::move(f);
    }
  }
  arv_stream_push_buffer(impl_->stream, buffer);  // always back into the pool
  return frame;
}

std::map<std::string, int64_t> GigeCamera::counters() const {
  if (connected_) const_cast<GigeCamera*>(this)->harvestStatistics();
  return counters_;
}

}  // namespace ips::drivers
