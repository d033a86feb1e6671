#include "ips/drivers/serial_port.hpp"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <string.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <stdexcept>

#include "ips/config.hpp"

namespace ips::drivers {
namespace {

[[noreturn]] void fail(const std::string& device, const std::string& what) {
  throw std::runtime_error("serial " + device + ": " + what + ": " + strerror(errno));
}

speed_t baudConstant(int baud) {
  switch (baud) {
    case 1200:
      return B1200;
    case 2400:
      return B2400;
    case 4800:
      return B4800;
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
    case 460800:
      return B460800;
    case 500000:
      return B500000;
    case 576000:
      return B576000;
    case 921600:
      return B921600;
    case 1000000:
      return B1000000;
    case 1152000:
      return B1152000;
    case 1500000:
      return B1500000;
    case 2000000:
      return B2000000;
    case 2500000:
      return B2500000;
    case 3000000:
      return B3000000;
    case 3500000:
      return B3500000;
    case 4000000:
      return B4000000;
    default:
      throw std::invalid_argument("serial: unsupported baud rate " + std::to_string(baud));
  }
}

}  // namespace

double SerialSettings::byteTimeUs() const {
  const int bits = 1 + data_bits + (parity == 'N' ? 0 : 1) + stop_bits;
  return 1e6 * bits / baud;
}

SerialSettings SerialSettings::fromConfig(const Config& c) {
  SerialSettings s;
  s.device = c.getString("device");
  s.baud = c.getInt("baud", s.baud);
  s.data_bits = c.getInt("data_bits", s.data_bits);
  const std::string parity = c.getString("parity", "N");
  if (parity.size() != 1 || std::string("NEO").find(parity[0]) == std::string::npos)
    throw ConfigError(c.path() + ": key 'parity' must be N, E or O");
  s.parity = parity[0];
  s.stop_bits = c.getInt("stop_bits", s.stop_bits);
  s.rts_cts = c.getBool("rts_cts", s.rts_cts);
  try {
    baudConstant(s.baud);
  } catch (const std::invalid_argument& e) {
    throw ConfigError(c.path() + ": key 'baud': " + e.what());
  }
  return s;
}

void SerialPort::configure(int fd, const SerialSettings& s) {
  if (s.data_bits < 5 || s.data_bits > 8)
    throw std::invalid_argument("serial " + s.device + ": data_bits must be 5..8, not " + std::to_string(s.data_bits));
  if (s.parity != 'N' && s.parity != 'E' && s.parity != 'O')
    throw std::invalid_argument("serial " + s.device + ": parity must be N, E or O");
  if (s.stop_bits != 1 && s.stop_bits != 2)
    throw std::invalid_argument("serial " + s.device + ": stop_bits must be 1 or 2");
  termios tio{};
  if (tcgetattr(fd, &tio) != 0) fail(s.device, "tcgetattr");
  cfmakeraw(&tio);
  const speed_t speed = baudConstant(s.baud);
  cfsetispeed(&tio, speed);
  cfsetospeed(&tio, speed);
  tio.c_cflag &= ~(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cflag |= s.data_bits == 5 ? CS5 : s.data_bits == 6 ? CS6 : s.data_bits == 7 ? CS7 : CS8;
  if (s.parity != 'N') {
    tio.c_cflag |= PARENB;
    if (s.parity == 'O') tio.c_cflag |= PARODD;
    tio.c_iflag |= INPCK;  // bytes with parity errors are not passed as good data
  }
  if (s.stop_bits == 2) tio.c_cflag |= CSTOPB;
  if (s.rts_cts) tio.c_cflag |= CRTSCTS;
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  if (tcsetattr(fd, TCSANOW, &tio) != 0) fail(s.device, "tcsetattr");
}

SerialPort::SerialPort(const SerialSettings& settings) : settings_(settings) {
  fd_ = ::open(settings.device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) fail(settings.device, "open");
  try {
    configure(fd_, settings);
    tcflush(fd_, TCIOFLUSH);  // bytes from before we opened have no meaningful arrival time
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

SerialPort::~SerialPort() {
  if (fd_ >= 0) ::close(fd_);
}

size_t SerialPort::read(uint8_t* buffer, size_t capacity, int timeout_ms) {
  pollfd pfd{fd_, POLLIN, 0};
  const int r = ::poll(&pfd, 1, timeout_ms);
  if (r < 0) {
    if (errno == EINTR) return 0;
    fail(settings_.device, "poll");
  }
  if (r == 0) return 0;
  if (pfd.revents & POLLIN) {
    const ssize_t n = ::read(fd_, buffer, capacity);
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) return 0;
      fail(settings_.device, "read");
    }
    if (n > 0) return static_cast<size_t>(n);
  }
  if (pfd.revents & (POLLHUP | POLLERR | POLLNVAL)) {
    errno = EIO;
    fail(settings_.device, "line hung up");
  }
  return 0;
}

void SerialPort::write(const uint8_t* data, size_t size, int timeout_ms) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  size_t done = 0;
  while (done < size) {
    const ssize_t n = ::write(fd_, data + done, size - done);
    if (n > 0) {
      done += static_cast<size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EINTR) fail(settings_.device, "write");
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      errno = ETIMEDOUT;
      fail(settings_.device, "write");
    }
    pollfd pfd{fd_, POLLOUT, 0};
    ::poll(&pfd, 1, static_cast<int>(left.count()));
  }
}

}  // namespace ips::drivers
