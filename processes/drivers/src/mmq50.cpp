#include "ips/drivers/mmq50.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "ips/config.hpp"

namespace ips::drivers {

Checksum parseChecksum(const std::string& name) {
  if (name == "none") return Checksum::None;
  if (name == "sum8") return Checksum::Sum8;
  if (name == "xor8") return Checksum::Xor8;
  if (name == "sum16") return Checksum::Sum16;
  if (name == "crc16_ccitt") return Checksum::Crc16Ccitt;
  throw std::invalid_argument("unknown checksum '" + name + "' (none, sum8, xor8, sum16, crc16_ccitt)");
}

size_t checksumBytes(Checksum type) {
  switch (type) {
    case Checksum::None:
      return 0;
    case Checksum::Sum8:
    case Checksum::Xor8:
      return 1;
    default:
      return 2;
  }
}

uint32_t computeChecksum(Checksum type, const uint8_t* data, size_t size) {
  uint32_t v = 0;
  switch (type) {
    case Checksum::None:
      return 0;
    case Checksum::Sum8:
      for (size_t i = 0; i < size; ++i) v += data[i];
      return v & 0xFF;
    case Checksum::Xor8:
      for (size_t i = 0; i < size; ++i) v ^= data[i];
      return v;
    case Checksum::Sum16:
      for (size_t i = 0; i < size; ++i) v += data[i];
      return v & 0xFFFF;
    case Checksum::Crc16Ccitt: {
      uint16_t crc = 0xFFFF;
      for (size_t i = 0; i < size; ++i) {
        crc ^= static_cast<uint16_t>(data[i]) << 8;
        for (int b = 0; b < 8; ++b) crc = (crc & 0x8000) ? static_cast<uint16_t>((crc << 1) ^ 0x1021) : crc << 1;
      }
      return crc;
    }
  }
  return 0;
}

namespace {

uint32_t readUnsigned(const uint8_t* p, int bytes, bool big_endian) {
  uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) {
    const int idx = big_endian ? i : bytes - 1 - i;
    v = (v << 8) | p[idx];
  }
  return v;
}

int32_t readSigned(const uint8_t* p, int bytes, bool big_endian) {
  const uint32_t u = readUnsigned(p, bytes, big_endian);
  if (bytes == 4) return static_cast<int32_t>(u);
  const uint32_t sign = 1u << (8 * bytes - 1);
  return static_cast<int32_t>((u ^ sign)) - static_cast<int32_t>(sign);
}

void writeUnsigned(std::vector<uint8_t>* out, uint32_t v, int bytes, bool big_endian) {
  for (int i = 0; i < bytes; ++i) {
    const int shift = big_endian ? 8 * (bytes - 1 - i) : 8 * i;
    out->push_back(static_cast<uint8_t>((v >> shift) & 0xFF));
  }
}

int64_t countsOf(double value, double lsb, int bytes) {
  const double limit = bytes == 2 ? 32767.0 : 2147483647.0;
  return static_cast<int64_t>(std::clamp(std::round(value / lsb), -limit, limit));
}

std::vector<uint8_t> parseHex(const std::string& text) {
  std::vector<uint8_t> out;
  std::string digits;
  for (char c : text)
    if (std::isxdigit(static_cast<unsigned char>(c))) digits += c;
  if (digits.empty() || digits.size() % 2) throw std::invalid_argument("sync must be an even number of hex digits");
  for (size_t i = 0; i < digits.size(); i += 2)
    out.push_back(static_cast<uint8_t>(std::stoul(digits.substr(i, 2), nullptr, 16)));
  return out;
}

}  // namespace

size_t Mmq50Format::packetSize() const {
  return sync.size() + counter_bytes + 3 * rate_bytes + 3 * accel_bytes + status_bytes + checksumBytes(checksum);
}

void Mmq50Format::validate() const {
  if (sync.empty()) throw std::invalid_argument("MMQ-50 format: sync needs at least one byte");
  if (counter_bytes != 1 && counter_bytes != 2)
    throw std::invalid_argument("MMQ-50 format: counter_bytes must be 1 or 2");
  if (rate_bytes != 2 && rate_bytes != 4) throw std::invalid_argument("MMQ-50 format: rate_bytes must be 2 or 4");
  if (accel_bytes != 2 && accel_bytes != 4) throw std::invalid_argument("MMQ-50 format: accel_bytes must be 2 or 4");
  if (status_bytes < 0 || status_bytes > 2) throw std::invalid_argument("MMQ-50 format: status_bytes must be 0..2");
  if (!(rate_lsb > 0) || !(accel_lsb > 0))
    throw std::invalid_argument("MMQ-50 format: rate_lsb and accel_lsb must be > 0");
  if (!(rate_hz > 0)) throw std::invalid_argument("MMQ-50 format: rate_hz must be > 0");
  std::array<bool, 3> used{};
  for (int i = 0; i < 3; ++i) {
    if (axis_map[i] < 0 || axis_map[i] > 2 || used[axis_map[i]])
      throw std::invalid_argument("MMQ-50 format: axis_map must be a permutation of 0 1 2");
    used[axis_map[i]] = true;
    if (axis_sign[i] != 1 && axis_sign[i] != -1) throw std::invalid_argument("MMQ-50 format: axis_sign must be +-1");
  }
}

Mmq50Format Mmq50Format::fromConfig(const Config& c) {
  Mmq50Format f;
  try {
    if (c.has("sync")) f.sync = parseHex(c.getString("sync"));
    f.counter_bytes = c.getInt("counter_bytes", f.counter_bytes);
    f.rate_bytes = c.getInt("rate_bytes", f.rate_bytes);
    f.accel_bytes = c.getInt("accel_bytes", f.accel_bytes);
    f.status_bytes = c.getInt("status_bytes", f.status_bytes);
    f.big_endian = c.getBool("big_endian", f.big_endian);
    f.rate_lsb = c.getDouble("rate_lsb", f.rate_lsb);
    f.accel_lsb = c.getDouble("accel_lsb", f.accel_lsb);
    if (c.has("checksum")) f.checksum = parseChecksum(c.getString("checksum"));
    f.status_ok_mask = static_cast<uint32_t>(c.getInt("status_ok_mask", 0));
    f.rate_hz = c.getDouble("rate_hz", f.rate_hz);
    if (c.has("axis_map")) {
      auto m = c.getMatrix("axis_map", 1, 3);
      for (int i = 0; i < 3; ++i) f.axis_map[i] = static_cast<int>(m(0, i));
    }
    if (c.has("axis_sign")) {
      auto m = c.getMatrix("axis_sign", 1, 3);
      for (int i = 0; i < 3; ++i) f.axis_sign[i] = static_cast<int>(m(0, i));
    }
    f.validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(c.path() + ": " + e.what());
  }
  return f;
}

Mmq50Parser::Mmq50Parser(Mmq50Format format) : format_(std::move(format)) { format_.validate(); }

void Mmq50Parser::dropPartial() {
  if (!buffer_.empty()) ++partial_frames_;
  buffer_.clear();
}

bool Mmq50Parser::decode(const uint8_t* p, ImuSample* out) {
  const Mmq50Format& f = format_;
  const uint8_t* q = p + f.sync.size();
  const uint32_t raw_counter = readUnsigned(q, f.counter_bytes, f.big_endian);
  q += f.counter_bytes;
  double rate[3], force[3];
  for (int i = 0; i < 3; ++i, q += f.rate_bytes) rate[i] = readSigned(q, f.rate_bytes, f.big_endian) * f.rate_lsb;
  for (int i = 0; i < 3; ++i, q += f.accel_bytes) force[i] = readSigned(q, f.accel_bytes, f.big_endian) * f.accel_lsb;
  const uint32_t status = f.status_bytes ? readUnsigned(q, f.status_bytes, f.big_endian) : 0;
  // The counter is unwrapped before the status check so that a bad sample is not counted as a gap too.
  const uint32_t modulus = 1u << (8 * f.counter_bytes);
  if (have_counter_) {
    const uint32_t step = (raw_counter + modulus - last_raw_counter_) % modulus;
    if (step == 0) {
      ++counters_.bad_frames;  // a repeated packet
      return false;
    }
    if (step > 1 && step < modulus / 2) counters_.counter_gaps += step - 1;
    unwrapped_counter_ += step < modulus / 2 ? step : 1;  // a huge step is a device restart: continue by one
  }
  have_counter_ = true;
  last_raw_counter_ = raw_counter;
  if (f.status_ok_mask && (status & f.status_ok_mask)) {
    ++counters_.bad_frames;
    return false;
  }
  out->counter = unwrapped_counter_;
  out->status = status;
  for (int i = 0; i < 3; ++i) {
    out->angular_rate[i] = f.axis_sign[i] * rate[f.axis_map[i]];
    out->specific_force[i] = f.axis_sign[i] * force[f.axis_map[i]];
  }
  return true;
}

std::vector<ImuSample> Mmq50Parser::feed(const uint8_t* data, size_t size, int64_t arrival_us, double byte_time_us) {
  std::vector<ImuSample> out;
  buffer_.insert(buffer_.end(), data, data + size);
  const size_t packet = format_.packetSize();
  const auto& sync = format_.sync;
  size_t pos = 0;
  while (buffer_.size() - pos >= 1) {
    // Find the next sync sequence (or a prefix of it at the very end of the buffer).
    size_t start = pos;
    while (start < buffer_.size()) {
      const size_t n = std::min(sync.size(), buffer_.size() - start);
      if (std::equal(sync.begin(), sync.begin() + n, buffer_.begin() + start)) break;
      ++start;
    }
    counters_.garbage_bytes += static_cast<int64_t>(start - pos);
    pos = start;
    if (buffer_.size() - pos < packet) break;  // wait for the rest
    const uint8_t* p = buffer_.data() + pos;
    const size_t body = packet - sync.size() - checksumBytes(format_.checksum);
    const uint32_t expected = computeChecksum(format_.checksum, p + sync.size(), body);
    const uint32_t stored =
        readUnsigned(p + sync.size() + body, static_cast<int>(checksumBytes(format_.checksum)), format_.big_endian);
    if (expected != stored) {
      ++counters_.checksum_errors;
      pos += 1;  // resynchronise on the next sync after this false or corrupt start
      continue;
    }
    ImuSample s;
    if (decode(p, &s)) {
      const size_t end = pos + packet;
      const size_t after = std::min(buffer_.size() - end, size);
      s.utime = arrival_us - static_cast<int64_t>(std::llround(after * byte_time_us));
      out.push_back(s);
      ++counters_.frames;
    }
    pos += packet;
  }
  buffer_.erase(buffer_.begin(), buffer_.begin() + pos);
  return out;
}

std::vector<uint8_t> Mmq50Parser::encode(const Mmq50Format& f, uint32_t counter, const double angular_rate[3],
                                         const double specific_force[3], uint32_t status) {
  // Inverse of the axis mapping: packet axis axis_map[i] holds IMU axis i.
  double rate[3], force[3];
  for (int i = 0; i < 3; ++i) {
    rate[f.axis_map[i]] = f.axis_sign[i] * angular_rate[i];
    force[f.axis_map[i]] = f.axis_sign[i] * specific_force[i];
  }
  std::vector<uint8_t> out(f.sync.begin(), f.sync.end());
  writeUnsigned(&out, counter & ((1u << (8 * f.counter_bytes)) - 1), f.counter_bytes, f.big_endian);
  for (int i = 0; i < 3; ++i)
    writeUnsigned(&out, static_cast<uint32_t>(countsOf(rate[i], f.rate_lsb, f.rate_bytes)), f.rate_bytes, f.big_endian);
  for (int i = 0; i < 3; ++i)
    writeUnsigned(&out, static_cast<uint32_t>(countsOf(force[i], f.accel_lsb, f.accel_bytes)), f.accel_bytes,
                  f.big_endian);
  if (f.status_bytes) writeUnsigned(&out, status, f.status_bytes, f.big_endian);
  const uint32_t sum = computeChecksum(f.checksum, out.data() + f.sync.size(), out.size() - f.sync.size());
  writeUnsigned(&out, sum, static_cast<int>(checksumBytes(f.checksum)), f.big_endian);
  return out;
}

}  // namespace ips::drivers
