#include "ips/drivers/pei_z260.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "ips/config.hpp"

namespace ips::drivers {

Z260Format Z260Format::fromConfig(const Config& c) {
  Z260Format f;
  f.x_prefix = c.getString("x_prefix", f.x_prefix);
  f.y_prefix = c.getString("y_prefix", f.y_prefix);
  f.degrees = c.getString("unit", "deg") == "deg";
  if (c.has("unit") && c.getString("unit") != "deg" && c.getString("unit") != "rad")
    throw ConfigError(c.path() + ": key 'unit' must be deg or rad");
  f.xor_checksum = c.getBool("xor_checksum", f.xor_checksum);
  f.max_line = static_cast<size_t>(c.getInt("max_line", static_cast<int>(f.max_line)));
  f.max_abs_angle_deg = c.getDouble("max_abs_angle_deg", f.max_abs_angle_deg);
  f.x_sign = c.getInt("x_sign", f.x_sign);
  f.y_sign = c.getInt("y_sign", f.y_sign);
  f.rate_hz = c.getDouble("rate_hz", f.rate_hz);
  if (f.x_prefix.empty() || f.y_prefix.empty() || f.x_prefix == f.y_prefix)
    throw ConfigError(c.path() + ": x_prefix and y_prefix must be distinct and non-empty");
  if ((f.x_sign != 1 && f.x_sign != -1) || (f.y_sign != 1 && f.y_sign != -1))
    throw ConfigError(c.path() + ": x_sign and y_sign must be +-1");
  if (!(f.rate_hz > 0) || f.max_line < 8) throw ConfigError(c.path() + ": rate_hz must be > 0 and max_line >= 8");
  return f;
}

Z260Parser::Z260Parser(Z260Format format) : format_(std::move(format)) {}

void Z260Parser::dropPartial() {
  if (!line_.empty()) ++partial_frames_;
  line_.clear();
  have_x_ = false;
  discarding_ = false;
}

bool Z260Parser::parseValue(const std::string& text, size_t* pos, const std::string& prefix, double* value_rad) {
  const size_t at = text.find(prefix, *pos);
  if (at == std::string::npos) return false;
  const char* begin = text.c_str() + at + prefix.size();
  char* end = nullptr;
  const double v = std::strtod(begin, &end);
  if (end == begin || !std::isfinite(v)) throw std::invalid_argument("no number after " + prefix);
  // The number must end at a separator: "+0#.000" is a corrupt "+00.000", not zero.
  if (*end != '\0' && *end != ' ' && *end != ',' && *end != ';' && *end != '\t')
    throw std::invalid_argument("corrupt number after " + prefix);
  const double deg = format_.degrees ? v : v * 180.0 / M_PI;
  if (std::fabs(deg) > format_.max_abs_angle_deg) throw std::invalid_argument("angle out of range");
  *value_rad = deg * M_PI / 180.0;
  *pos = static_cast<size_t>(end - text.c_str());
  return true;
}

void Z260Parser::handleLine(int64_t utime, std::vector<TiltSample>* out) {
  std::string text = line_;
  line_.clear();
  if (text.empty()) return;
  if (format_.xor_checksum) {
    const size_t star = text.rfind('*');
    if (star == std::string::npos || star + 3 != text.size()) {
      ++counters_.checksum_errors;
      have_x_ = false;
      return;
    }
    unsigned sum = 0;
    for (size_t i = (text[0] == '$' ? 1 : 0); i < star; ++i) sum ^= static_cast<unsigned char>(text[i]);
    char* end = nullptr;
    const unsigned long stored = std::strtoul(text.c_str() + star + 1, &end, 16);
    if (end != text.c_str() + text.size() || stored != sum) {
      ++counters_.checksum_errors;
      have_x_ = false;
      return;
    }
    text.resize(star);
  }
  double x = 0, y = 0;
  bool has_x = false, has_y = false;
  try {
    size_t pos = 0;
    has_x = parseValue(text, &pos, format_.x_prefix, &x);
    if (!has_x) pos = 0;
    has_y = parseValue(text, &pos, format_.y_prefix, &y);
  } catch (const std::invalid_argument&) {
    ++counters_.bad_frames;
    have_x_ = false;
    return;
  }
  if (has_x && !has_y) {
    if (have_x_) ++counters_.bad_frames;  // an X without its Y before it
    have_x_ = true;
    pending_x_ = x;
    return;
  }
  if (has_y && !has_x) {
    if (!have_x_) {
      ++counters_.bad_frames;  // a Y whose X was lost
      return;
    }
    x = pending_x_;
  }
  if (!has_x && !has_y) {
    counters_.garbage_bytes += static_cast<int64_t>(text.size());
    return;
  }
  have_x_ = false;
  TiltSample s;
  s.utime = utime;
  s.seq = seq_++;
  s.angle_x = format_.x_sign * x;
  s.angle_y = format_.y_sign * y;
  out->push_back(s);
  ++counters_.frames;
}

std::vector<TiltSample> Z260Parser::feed(const uint8_t* data, size_t size, int64_t arrival_us, double byte_time_us) {
  std::vector<TiltSample> out;
  for (size_t i = 0; i < size; ++i) {
    const char c = static_cast<char>(data[i]);
    if (c == '\n' || c == '\r') {
      if (discarding_) {
        discarding_ = false;
        line_.clear();
        continue;
      }
      const int64_t utime = arrival_us - static_cast<int64_t>(std::llround((size - 1 - i) * byte_time_us));
      handleLine(utime, &out);
      continue;
    }
    if (discarding_) {
      ++counters_.garbage_bytes;
      continue;
    }
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7E ||
        line_.size() >= format_.max_line) {
      // Line noise (not text) or an overlong line: the rest of this line cannot be trusted either.
      counters_.garbage_bytes += static_cast<int64_t>(line_.size()) + 1;
      line_.clear();
      have_x_ = false;
      discarding_ = true;
      continue;
    }
    line_ += c;
  }
  return out;
}

std::string Z260Parser::format(const Z260Format& f, double angle_x_rad, double angle_y_rad) {
  const double k = f.degrees ? 180.0 / M_PI : 1.0;
  char body[96];
  std::snprintf(body, sizeof body, "%s%+07.3f %s%+07.3f", f.x_prefix.c_str(), f.x_sign * angle_x_rad * k,
                f.y_prefix.c_str(), f.y_sign * angle_y_rad * k);
  std::string line = body;
  if (f.xor_checksum) {
    unsigned sum = 0;
    for (char c : line) sum ^= static_cast<unsigned char>(c);
    char tail[8];
    std::snprintf(tail, sizeof tail, "*%02X", sum);
    line += tail;
  }
  return line + "\r\n";
}

}  // namespace ips::drivers
