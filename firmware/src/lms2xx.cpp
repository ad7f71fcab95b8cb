// odoerr firmware: SICK LMS2xx telegram parser (format, CRC and resync rules in the header).
#include "odoerr/drivers/lms2xx.hpp"

#include <cstring>
#include <limits>

namespace odoerr::drivers {

namespace {

constexpr std::uint16_t le16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}

}  // namespace

Lms2xxParser::Lms2xxParser(const Config& config) : cfg_(config) {
  if (cfg_.baud == 0) cfg_.baud = 38400;
  if (cfg_.max_values < 1) cfg_.max_values = 1;
  if (cfg_.max_values > kMaxValues) cfg_.max_values = kMaxValues;
  switch (cfg_.mode) {
    case MeasuringMode::kRange8mFieldsABDazzle:
      dist_mask_ = 0x1FFF;
      dazzle_bit_ = true;
      break;
    case MeasuringMode::kRange8mReflector:
    case MeasuringMode::kRange8mFieldsABC:
      dist_mask_ = 0x1FFF;
      dazzle_bit_ = false;
      break;
    case MeasuringMode::kRange16mReflector:
    case MeasuringMode::kRange16mFieldsAB:
      dist_mask_ = 0x3FFF;
      dazzle_bit_ = false;
      break;
    case MeasuringMode::kRange32mReflector:
    case MeasuringMode::kRange32mFieldA:
    default:
      dist_mask_ = 0x7FFF;
      dazzle_bit_ = false;
      break;
  }
}

std::uint16_t Lms2xxParser::crc16(const std::uint8_t* data, std::size_t n) {
  std::uint16_t crc = 0;
  std::uint8_t prev = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t b = data[i];
    if (crc & 0x8000u) {
      crc = static_cast<std::uint16_t>(((crc & 0x7FFFu) << 1) ^ 0x8005u);
    } else {
      crc = static_cast<std::uint16_t>(crc << 1);
    }
    crc = static_cast<std::uint16_t>(crc ^ (b | (prev << 8)));
    prev = b;
  }
  return crc;
}

std::uint64_t Lms2xxParser::transmissionTimeUs(std::uint64_t bytes, std::uint32_t baud) {
  if (baud == 0) return 0;
  return (bytes * 10u * 1000000u + baud / 2u) / baud;
}

void Lms2xxParser::reset() {
  counters_.bytes_discarded += tail_ - head_;  // keep the byte balance
  abs_head_ += tail_ - head_;
  head_ = tail_ = 0;
  outer_total_ = 0;
  n_inner_ = 0;
  fail_pending_ = false;
  scan_ready_ = false;
  new_scan_ = false;
}

bool Lms2xxParser::feed(const std::uint8_t* data, std::size_t n, std::uint64_t arrival_us) {
  new_scan_ = false;
  if (data == nullptr || n == 0) return false;
  chunk_arrival_us_ = arrival_us;
  chunk_end_ = absTail() + n;
  for (std::size_t i = 0; i < n; ++i) push(data[i]);
  return new_scan_;
}

hal::Status Lms2xxParser::poll(hal::SerialPort& port, std::uint64_t now_us) {
  constexpr int kMaxReads = 32;
  std::uint8_t chunk[64];
  hal::Status result = hal::Status::kOk;
  for (int r = 0; r < kMaxReads; ++r) {
    std::size_t n = 0;
    const hal::Status s = port.read(chunk, sizeof chunk, &n);
    if (s == hal::Status::kDataLoss) {
      ++counters_.uart_overruns;
      result = hal::Status::kDataLoss;
    } else if (s != hal::Status::kOk) {
      return s;
    }
    if (n == 0) break;
    (void)feed(chunk, n, now_us);
  }
  return result;
}

hal::Status Lms2xxParser::takeScan(float* ranges, int capacity, ScanInfo* info) {
  if (!scan_ready_) return hal::Status::kUnavailable;
  if ((ranges == nullptr && info_.count > 0) || capacity < info_.count) {
    return hal::Status::kInvalidArgument;
  }
  for (int i = 0; i < info_.count; ++i) ranges[i] = ranges_[i];
  if (info != nullptr) *info = info_;
  scan_ready_ = false;
  return hal::Status::kOk;
}

// --- byte machine ------------------------------------------------------------------------

void Lms2xxParser::push(std::uint8_t b) {
  ++counters_.bytes_fed;
  if (tail_ == kMaxTelegram) {  // compact; fewer than kMaxTelegram bytes are ever pending
    std::memmove(buf_, buf_ + head_, tail_ - head_);
    tail_ -= head_;
    head_ = 0;
  }
  buf_[tail_++] = b;
  if (outer_total_ > 0 && tail_ - head_ < outer_total_) {
    // Waiting for the rest of the candidate at head_: a header that just became complete
    // behind it is tracked; a tracked telegram that just became complete and is valid
    // wins over the candidate.
    noteInnerHeaderAtTail();
    if (!acceptInnerEndingAtTail()) return;
  }
  process();
}

// True if idx holds STX, the expected address and a LEN in range (needs 4 bytes).
bool Lms2xxParser::headerAt(std::size_t idx, std::size_t* total) const {
  if (buf_[idx] != kStx || buf_[idx + 1] != cfg_.expected_address) return false;
  const std::size_t len = le16(&buf_[idx + 2]);
  if (len < 1 || len > kMaxLen) return false;
  *total = len + kOverhead;
  return true;
}

bool Lms2xxParser::crcOkAt(std::size_t idx, std::size_t total) const {
  return crc16(&buf_[idx], total - 2) == le16(&buf_[idx + total - 2]);
}

void Lms2xxParser::process() {
  for (;;) {
    const std::size_t avail = tail_ - head_;
    if (avail == 0) {
      head_ = tail_ = 0;
      return;
    }
    if (outer_total_ == 0) {
      if (buf_[head_] != kStx) {
        discard(1);
        continue;
      }
      if (avail < 2) return;
      if (buf_[head_ + 1] != cfg_.expected_address) {
        discard(1);
        continue;
      }
      if (avail < 4) return;
      const std::size_t len = le16(&buf_[head_ + 2]);
      if (len < 1 || len > kMaxLen) {
        if (!fail_pending_) ++counters_.wrong_length;
        discard(1);
        continue;
      }
      outer_total_ = len + kOverhead;
      n_inner_ = 0;
      if (avail < outer_total_) {
        if (scanBufferedInners()) continue;
        return;
      }
    }
    if (avail < outer_total_) return;
    if (crcOkAt(head_, outer_total_)) {
      acceptAtHead();
      continue;
    }
    registerFailure(abs_head_ + outer_total_);
    outer_total_ = 0;
    n_inner_ = 0;
    discard(1);  // resume the hunt at the byte after the false STX
  }
}

// A candidate was just established at head_ with bytes already buffered behind it (after a
// rescan): accept the first complete valid telegram among them, track the incomplete ones.
bool Lms2xxParser::scanBufferedInners() {
  for (std::size_t p = head_ + 1; p + 4 <= tail_; ++p) {
    std::size_t total = 0;
    if (!headerAt(p, &total)) continue;
    if (p + total <= tail_) {
      if (crcOkAt(p, total)) {
        abandonOuterFor(p);
        acceptAtHead();
        return true;
      }
    } else if (n_inner_ < kMaxInner) {
      const std::uint64_t start = abs_head_ + (p - head_);
      inner_[n_inner_++] = Inner{start, start + total};
    }
  }
  return false;
}

void Lms2xxParser::noteInnerHeaderAtTail() {
  if (tail_ - head_ < 5) return;  // the header must start after head_
  const std::size_t p = tail_ - 4;
  std::size_t total = 0;
  if (!headerAt(p, &total) || n_inner_ >= kMaxInner) return;
  const std::uint64_t start = abs_head_ + (p - head_);
  inner_[n_inner_++] = Inner{start, start + total};
}

bool Lms2xxParser::acceptInnerEndingAtTail() {
  const std::uint64_t now_end = absTail();
  for (int i = 0; i < n_inner_;) {
    if (inner_[i].end != now_end) {
      ++i;
      continue;
    }
    const std::size_t idx = indexOf(inner_[i].start);
    if (crcOkAt(idx, static_cast<std::size_t>(inner_[i].end - inner_[i].start))) {
      abandonOuterFor(idx);
      acceptAtHead();
      return true;
    }
    for (int j = i + 1; j < n_inner_; ++j) inner_[j - 1] = inner_[j];  // keep start order
    --n_inner_;
  }
  return false;
}

void Lms2xxParser::abandonOuterFor(std::size_t idx) {
  registerFailure(abs_head_ + outer_total_);
  outer_total_ = 0;
  n_inner_ = 0;
  discard(idx - head_);
}

void Lms2xxParser::registerFailure(std::uint64_t end) {
  if (fail_pending_) {
    if (end > fail_end_) fail_end_ = end;
  } else {
    fail_pending_ = true;
    fail_end_ = end;
  }
}

void Lms2xxParser::discard(std::size_t k) {
  head_ += k;
  abs_head_ += k;
  counters_.bytes_discarded += k;
  if (fail_pending_ && abs_head_ >= fail_end_) {
    ++counters_.bad_crc;
    fail_pending_ = false;
  }
}

void Lms2xxParser::acceptAtHead() {
  const std::size_t total = le16(&buf_[head_ + 2]) + kOverhead;
  if (fail_pending_) {  // a valid telegram starts inside the rejected span
    ++counters_.truncated;
    fail_pending_ = false;
  }
  handleTelegram(&buf_[head_], total);
  head_ += total;
  abs_head_ += total;
  counters_.bytes_in_telegrams += total;
  outer_total_ = 0;
  n_inner_ = 0;
}

// t: a CRC-valid telegram of `total` bytes at stream position abs_head_.
void Lms2xxParser::handleTelegram(const std::uint8_t* t, std::size_t total) {
  const std::size_t len = total - kOverhead;
  if (t[4] != kCmdMeasuredValues) {
    ++counters_.other_telegrams;
    return;
  }
  if (len < 4) {  // CMD, count word, STATUS
    ++counters_.wrong_length;
    return;
  }
  const std::uint8_t* data = t + 5;
  const std::size_t data_len = len - 2;
  const std::uint16_t cw = le16(data);
  const int n = cw & 0x03FF;
  const std::size_t plain = 2 + 2 * static_cast<std::size_t>(n);
  bool has_rt = false;
  if (data_len == plain + 1) {
    has_rt = true;
  } else if (data_len != plain) {
    ++counters_.wrong_length;
    return;
  }
  if (n > cfg_.max_values) {
    ++counters_.wrong_length;
    return;
  }
  const unsigned unit = cw >> 14;
  if (unit > 1) {
    ++counters_.bad_unit;
    return;
  }

  if (scan_ready_) ++counters_.scans_overwritten;
  const float divisor = unit == 1 ? 1000.0f : 100.0f;
  const std::uint16_t first_code = static_cast<std::uint16_t>(dist_mask_ - 8);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int i = 0; i < n; ++i) {
    const std::uint16_t w = le16(data + 2 + 2 * i);
    const std::uint16_t d = static_cast<std::uint16_t>(w & dist_mask_);
    if ((dazzle_bit_ && (w & 0x8000u)) || d >= first_code) {
      ranges_[i] = nan;
    } else {
      ranges_[i] = static_cast<float>(d) / divisor;
    }
  }

  ++counters_.frames_ok;
  info_.count = n;
  info_.status = t[total - 3];
  info_.unit_mm = unit == 1;
  info_.partial = (cw & 0x2000u) != 0;
  info_.partial_index = static_cast<std::uint8_t>((cw >> 11) & 0x3u);
  info_.has_realtime_index = has_rt;
  info_.realtime_index = has_rt ? data[plain] : 0;
  info_.sequence = counters_.frames_ok;
  // Line time from this telegram's STX to the chunk's last byte, plus the scanner latency.
  const std::uint64_t back =
      transmissionTimeUs(chunk_end_ - abs_head_, cfg_.baud) + cfg_.latency_us;
  info_.stamp_us = chunk_arrival_us_ > back ? chunk_arrival_us_ - back : 0;
  scan_ready_ = true;
  new_scan_ = true;
}

}  // namespace odoerr::drivers
