// fw_replay: the firmware application (fw/app.hpp) over HAL implementations that replay a
// HAL tape (fw/hal_tape.hpp): the clock, both counters and the laser's serial bytes are
// what the devices showed at each poll. Telemetry frames go to telemetry.bin; the exit
// code is 0 on success. Host build: the file names are the first two arguments.
#include <cstdint>
#include <cstdio>
#include <new>

#include "odoerr/fw/app.hpp"
#include "odoerr/fw/hal_tape.hpp"
#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/hal/fake_param_store.hpp"

#include "../replay_io.hpp"

namespace io = odoerr::replay_io;

using namespace odoerr;

namespace {

/// The devices as the tape says they were at the current poll.
struct TapeDevices {
  class Clock final : public hal::Clock {
   public:
    std::uint64_t now = 0;
   private:
    std::uint64_t DoNowUs() const override { return now; }
  };
  class Counter final : public hal::EncoderCounter {
   public:
    explicit Counter(std::uint8_t bits) : bits_(bits) {}
    std::uint32_t raw = 0;
   private:
    hal::Status DoRead(std::uint32_t* c) override {
      *c = raw;
      return hal::Status::kOk;
    }
    std::uint8_t DoBits() const override { return bits_; }
    std::uint8_t bits_;
  };
  class Serial final : public hal::SerialPort {
   public:
    std::uint8_t buf[1024];
    std::size_t n = 0;
    std::size_t pos = 0;
   private:
    hal::Status DoRead(std::uint8_t* out, std::size_t cap, std::size_t* got) override {
      while (*got < cap && pos < n) out[(*got)++] = buf[pos++];
      return hal::Status::kOk;
    }
    hal::Status DoWrite(const std::uint8_t*, std::size_t k, std::size_t* w) override {
      *w = k;
      return hal::Status::kOk;
    }
  };
  class Telemetry final : public hal::TelemetrySink {
   public:
    int handle = -1;
   private:
    hal::Status DoSend(const std::uint8_t* f, std::size_t k) override {
      return io::write(handle, f, k) == k ? hal::Status::kOk : hal::Status::kResourceExhausted;
    }
  };
};

/// Static storage for an object constructed in place and never destroyed (as firmware
/// state is: no atexit registration, no heap); it lives in .bss, not on the stack.
template <typename T>
struct Static {
  alignas(T) unsigned char bytes[sizeof(T)];
  template <typename... A>
  T& make(A&&... args) {
    return *new (bytes) T(static_cast<A&&>(args)...);
  }
};

template <template <typename> class DriveT>
int run(int in, int out, const fw::HalTapeHeader& h) {
  using Est = typename fw::PaperTypes<float, DriveT>::EstimatorT;
  using AppT = fw::App<Est>;
  using Store = hal::FakeParamStore<4096, 1024>;
  static Static<Est> est_mem;
  static Static<Store> store_mem;
  static Static<AppT> app_mem;
  typename DriveT<float>::NonSysVec k0;
  for (int i = 0; i < k0.size(); ++i) k0[i] = h.k0[i];
  fw::FilterSetup setup;
  const Pose<double> start{static_cast<double>(h.x0), static_cast<double>(h.y0), static_cast<double>(h.theta0)};
  Est& est = est_mem.make(fw::makePaperEstimator<float, DriveT>(setup, start, k0));
  TapeDevices::Clock clock;
  TapeDevices::Counter a(static_cast<std::uint8_t>(h.counter_bits));
  TapeDevices::Counter b(static_cast<std::uint8_t>(h.counter_bits));
  TapeDevices::Serial serial;
  TapeDevices::Telemetry tm;
  tm.handle = out;
  Store& store = store_mem.make();  // RAM-backed flash of the emulated board
  fw::AppConfig ac;
  ac.ticks_per_unit_a = h.ticks_a;
  ac.ticks_per_unit_b = h.ticks_b;
  ac.drive_id = static_cast<std::uint8_t>(h.drive);
  drivers::EncoderConfig ec;
  ec.max_ticks_per_s = 60000;
  drivers::Lms2xxConfig lc;
  lc.baud = h.baud;
  AppT& app = app_mem.make(a, b, serial, clock, store, tm, est, ac, ec, lc);
  std::uint8_t rec[fw::kHalTapePollBytes];
  for (std::uint32_t k = 0; k < h.polls; ++k) {
    if (io::read(in, rec, sizeof rec) != sizeof rec) return 3;
    clock.now = std::uint64_t(fw::getU32(rec)) | (std::uint64_t(fw::getU32(rec + 4)) << 32);
    a.raw = fw::getU32(rec + 8);
    b.raw = fw::getU32(rec + 12);
    serial.n = std::size_t(rec[16]) | (std::size_t(rec[17]) << 8);
    serial.pos = 0;
    if (serial.n > sizeof serial.buf || io::read(in, serial.buf, serial.n) != serial.n) return 3;
    if (k == 0) {
      if (!hal::ok(app.boot())) return 5;
    } else {
      app.poll();
    }
  }
  // fwstats.bin: u32 stack high-water (target; 0 on the host) | u32 sizeof estimator |
  // u32 sizeof application (drivers, queues, parser buffers) | u32 cycles
  std::uint8_t st[16];
  fw::putU32(st, io::stackHighWater());
  fw::putU32(st + 4, static_cast<std::uint32_t>(sizeof(Est)));
  fw::putU32(st + 8, static_cast<std::uint32_t>(sizeof(app)));
  fw::putU32(st + 12, app.health().cycles);
  const int sf = io::openWrite("fwstats.bin");
  if (sf >= 0) (void)io::write(sf, st, sizeof st);
  return app.health().cycles > 0 ? 0 : 6;
}

}  // namespace

int main(int argc, char** argv) {
  const io::Paths p = io::paths(argc, argv, "haltape.bin", "telemetry.bin");
  const int in = io::openRead(p.in);
  if (in < 0) return 10;
  const int out = io::openWrite(p.out);
  if (out < 0) return 11;
  std::uint8_t hb[fw::kHalTapeHeaderBytes];
  fw::HalTapeHeader h;
  if (io::read(in, hb, sizeof hb) != sizeof hb || !fw::decodeHalTapeHeader(hb, &h)) return 2;
  return h.drive == 0 ? run<SyncDrive>(in, out, h) : run<DiffDrive>(in, out, h);
}
