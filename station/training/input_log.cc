#include "station/training/input_log.h"

#include <zlib.h>

#include <array>
#include <cmath>
#include <cstring>
#include <limits>

namespace ves::training {
namespace {

constexpr char kMagicV1[4] = {'V', 'I', 'L', '1'};
constexpr char kMagicV2[4] = {'V', 'I', 'L', '2'};
constexpr std::size_t kHeaderBytes = 4 + 8 + 4 + 4 + 4;
// Version 1 logged the first 9 columns; version 2 added the abdominal press
// and the patient's position after them.
constexpr int kColumnsV1 = 9;
constexpr int kColumns = 11;
// A varint of a zig-zag int64 takes at most 10 bytes.
constexpr std::uint64_t kMaxVarintBytes = 10;
// Refuse absurd headers before allocating: 2^28 samples is 74 h at 1 kHz.
constexpr std::uint64_t kMaxSamples = std::uint64_t{1} << 28;
constexpr double kMaxQuantized = 1e15;
// The log's thrust-mode column holds the model's enum as a number: these
// values are the wire format and must never change.
static_assert(static_cast<int>(ThrustMode::kPosition) == 0);
static_assert(static_cast<int>(ThrustMode::kForce) == 1);

std::int64_t ToUnits(double value, double resolution, const char* field) {
  const double units = std::round(value / resolution);
  if (!std::isfinite(value) || std::abs(units) > kMaxQuantized) {
    throw std::invalid_argument(std::string("input sample: ") + field +
                                " is not a finite value in range: " + std::to_string(value));
  }
  return static_cast<std::int64_t>(units);
}

std::array<std::int64_t, kColumns> ToColumns(const InputSample& s) {
  return {static_cast<std::int64_t>(s.tick),
          static_cast<std::int64_t>(s.thrust_mode),
          ToUnits(s.insertion_m, kLogLengthResolution_m, "insertion_m"),
          ToUnits(s.push_force_N, kLogForceResolution_N, "push_force_N"),
          ToUnits(s.roll_rad, kLogAngleResolution_rad, "roll_rad"),
          ToUnits(s.knob_up_rad, kLogAngleResolution_rad, "knob_up_rad"),
          ToUnits(s.knob_right_rad, kLogAngleResolution_rad, "knob_right_rad"),
          static_cast<std::int64_t>(s.view_mode),
          s.fluoroscopy_on ? 1 : 0,
          static_cast<std::int64_t>(s.abdominal_press),
          static_cast<std::int64_t>(s.patient_position)};
}

int ColumnsOf(std::uint32_t format_version) {
  return format_version == 1 ? kColumnsV1 : kColumns;
}

// Column c of ToColumns back into the sample; throws InputLogError for a
// value no sample can have.
void SetColumn(InputSample* s, int c, std::int64_t v) {
  switch (c) {
    case 0:
      if (v < 0) throw InputLogError("input log: negative tick " + std::to_string(v));
      s->tick = static_cast<std::uint64_t>(v);
      return;
    case 1:
      if (v < 0 || v > 1) throw InputLogError("input log: bad thrust mode " + std::to_string(v));
      s->thrust_mode = static_cast<ThrustMode>(v);
      return;
    case 2: s->insertion_m = static_cast<double>(v) * kLogLengthResolution_m; return;
    case 3: s->push_force_N = static_cast<double>(v) * kLogForceResolution_N; return;
    case 4: s->roll_rad = static_cast<double>(v) * kLogAngleResolution_rad; return;
    case 5: s->knob_up_rad = static_cast<double>(v) * kLogAngleResolution_rad; return;
    case 6: s->knob_right_rad = static_cast<double>(v) * kLogAngleResolution_rad; return;
    case 7:
      if (v < 0 || v > 2) throw InputLogError("input log: bad view mode " + std::to_string(v));
      s->view_mode = static_cast<ViewMode>(v);
      return;
    case 8:
      if (v < 0 || v > 1) {
        throw InputLogError("input log: bad fluoroscopy flag " + std::to_string(v));
      }
      s->fluoroscopy_on = v == 1;
      return;
    case 9:
      if (v < 0 || v > 2) {
        throw InputLogError("input log: bad abdominal_press " + std::to_string(v) +
                            " (0 none, 1 left lower quadrant, 2 mid-abdomen)");
      }
      s->abdominal_press = static_cast<AbdominalPress>(v);
      return;
    default:
      if (v < 0 || v > 2) {
        throw InputLogError("input log: bad patient_position " + std::to_string(v) +
                            " (0 supine, 1 left lateral, 2 right lateral)");
      }
      s->patient_position = static_cast<PatientPosition>(v);
      return;
  }
}

InputSample FromColumns(const std::array<std::int64_t, kColumns>& c) {
  InputSample s;
  for (int column = 0; column < kColumns; ++column) SetColumn(&s, column, c[column]);
  return s;
}

void PutVarint(std::string* out, std::int64_t value) {
  // Zig-zag so small negative deltas stay short.
  std::uint64_t v =
      (static_cast<std::uint64_t>(value) << 1) ^ static_cast<std::uint64_t>(value >> 63);
  while (v >= 0x80) {
    out->push_back(static_cast<char>((v & 0x7f) | 0x80));
    v >>= 7;
  }
  out->push_back(static_cast<char>(v));
}

std::int64_t GetVarint(std::string_view raw, std::size_t* pos) {
  std::uint64_t v = 0;
  for (int shift = 0; shift < 64; shift += 7) {
    if (*pos >= raw.size()) throw InputLogError("input log: data ends inside a value");
    const auto byte = static_cast<std::uint8_t>(raw[(*pos)++]);
    v |= static_cast<std::uint64_t>(byte & 0x7f) << shift;
    if ((byte & 0x80) == 0) {
      return static_cast<std::int64_t>(v >> 1) ^ -static_cast<std::int64_t>(v & 1);
    }
  }
  throw InputLogError("input log: malformed value (varint longer than 10 bytes)");
}

void PutLe(std::string* out, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

std::uint64_t GetLe(std::string_view in, std::size_t at, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) {
    v |= static_cast<std::uint64_t>(static_cast<std::uint8_t>(in[at + i])) << (8 * i);
  }
  return v;
}

std::uint32_t Crc32(std::string_view data) {
  return static_cast<std::uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(data.data()), static_cast<uInt>(data.size())));
}

}  // namespace

InputSample Quantize(const InputSample& sample) { return FromColumns(ToColumns(sample)); }

std::string_view InputLogEncodingOf(std::uint32_t format_version) {
  switch (format_version) {
    case 1: return "delta-zlib-v1";
    case 2: return kInputLogEncoding;
    default: return {};
  }
}

std::string EncodeInputSamples(std::span<const InputSample> samples,
                               std::uint32_t format_version) {
  if (InputLogEncodingOf(format_version).empty()) {
    throw std::invalid_argument("input log: cannot encode format version " +
                                std::to_string(format_version));
  }
  const int columns = ColumnsOf(format_version);
  std::vector<std::array<std::int64_t, kColumns>> rows;
  rows.reserve(samples.size());
  for (const InputSample& s : samples) {
    rows.push_back(ToColumns(s));
    for (int c = columns; c < kColumns; ++c) {
      if (rows.back()[c] != 0) {
        throw std::invalid_argument("input log: format version " +
                                    std::to_string(format_version) +
                                    " has no abdominal press or patient position (tick " +
                                    std::to_string(s.tick) + ")");
      }
    }
  }
  std::string raw;
  raw.reserve(samples.size() * columns * 2);
  for (int c = 0; c < columns; ++c) {
    std::int64_t previous = 0;
    for (const auto& row : rows) {
      PutVarint(&raw, row[c] - previous);
      previous = row[c];
    }
  }
  if (raw.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw std::invalid_argument("input log: too many samples to encode: " +
                                std::to_string(samples.size()));
  }
  uLongf packed_size = compressBound(static_cast<uLong>(raw.size()));
  std::string packed(packed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(packed.data()), &packed_size,
                reinterpret_cast<const Bytef*>(raw.data()), static_cast<uLong>(raw.size()),
                Z_BEST_COMPRESSION) != Z_OK) {
    throw std::runtime_error("input log: zlib compression failed");
  }
  packed.resize(packed_size);

  std::string out(format_version == 1 ? kMagicV1 : kMagicV2, 4);
  PutLe(&out, samples.size(), 8);
  PutLe(&out, raw.size(), 4);
  PutLe(&out, Crc32(raw), 4);
  // A second CRC over the compressed bytes: deflate ignores the padding bits
  // of its last byte, and a flip there must still be caught.
  PutLe(&out, Crc32(packed), 4);
  out += packed;
  return out;
}

std::vector<InputSample> DecodeInputSamples(std::string_view encoded) {
  const std::uint64_t count = PeekInputSampleCount(encoded);
  const int columns = ColumnsOf(PeekInputLogFormatVersion(encoded));
  const std::uint64_t raw_size = GetLe(encoded, 12, 4);
  const auto crc = static_cast<std::uint32_t>(GetLe(encoded, 16, 4));
  const auto packed_crc = static_cast<std::uint32_t>(GetLe(encoded, 20, 4));
  if (count > kMaxSamples) {
    throw InputLogError("input log: implausible sample count " + std::to_string(count));
  }
  if (raw_size < count * columns || raw_size > count * columns * kMaxVarintBytes) {
    throw InputLogError("input log: raw length " + std::to_string(raw_size) +
                        " does not fit sample count " + std::to_string(count));
  }
  const std::string_view packed = encoded.substr(kHeaderBytes);
  // zlib cannot expand more than about 1032:1; a larger claim is a corrupted header.
  if (raw_size > (packed.size() + 64) * 1100) {
    throw InputLogError("input log: raw length " + std::to_string(raw_size) + " impossible for " +
                        std::to_string(packed.size()) + " compressed bytes");
  }
  if (Crc32(packed) != packed_crc) {
    throw InputLogError(
        "input log: CRC-32 mismatch of the compressed data (truncated or corrupted)");
  }
  std::string raw(raw_size, '\0');
  uLongf raw_out = static_cast<uLongf>(raw_size);
  const int z =
      uncompress(reinterpret_cast<Bytef*>(raw.data()), &raw_out,
                 reinterpret_cast<const Bytef*>(packed.data()), static_cast<uLong>(packed.size()));
  if (z != Z_OK || raw_out != raw_size) {
    throw InputLogError(
        std::string("input log: compressed data is truncated or corrupted (zlib: ") +
        (z == Z_OK ? "length mismatch" : zError(z)) + ")");
  }
  if (Crc32(raw) != crc) throw InputLogError("input log: CRC-32 mismatch (corrupted data)");

  // Column by column straight into the samples: no second copy of the log.
  // A version 1 log's samples keep the later columns' defaults.
  std::vector<InputSample> samples(count);
  std::size_t pos = 0;
  for (int c = 0; c < columns; ++c) {
    std::int64_t value = 0;
    for (InputSample& sample : samples) {
      const std::int64_t delta = GetVarint(raw, &pos);
      // Wrapping add: corrupted deltas must not be undefined behaviour.
      value = static_cast<std::int64_t>(static_cast<std::uint64_t>(value) +
                                        static_cast<std::uint64_t>(delta));
      SetColumn(&sample, c, value);
    }
  }
  if (pos != raw.size()) {
    throw InputLogError("input log: " + std::to_string(raw.size() - pos) +
                        " unexpected bytes after the samples");
  }
  return samples;
}

std::uint32_t PeekInputLogFormatVersion(std::string_view encoded) {
  if (encoded.size() < kHeaderBytes) {
    throw InputLogError("input log: truncated header (" + std::to_string(encoded.size()) +
                        " bytes, need " + std::to_string(kHeaderBytes) + ")");
  }
  if (std::memcmp(encoded.data(), kMagicV1, 4) == 0) return 1;
  if (std::memcmp(encoded.data(), kMagicV2, 4) == 0) return 2;
  throw InputLogError("input log: not a delta-zlib-v1 or -v2 log (bad magic)");
}

std::uint64_t PeekInputSampleCount(std::string_view encoded) {
  PeekInputLogFormatVersion(encoded);  // checks the header's size and magic
  return GetLe(encoded, 4, 8);
}

std::uint64_t MaxSessionSamples(double time_limit_s, double dt_s) {
  if (!(time_limit_s > 0.0) || !(dt_s > 0.0) || !std::isfinite(time_limit_s / dt_s)) return 0;
  // A session logs one sample per step and ends at the step reaching the
  // limit (within half a step); one more for rounding.
  const double steps = std::floor(time_limit_s / dt_s + 0.5) + 1.0;
  return steps >= 1e18 ? std::numeric_limits<std::uint64_t>::max()
                       : static_cast<std::uint64_t>(steps);
}

v1::InputLog MakeInputLog(std::span<const InputSample> samples, double dt_s,
                          std::uint32_t format_version) {
  v1::InputLog log;
  log.set_format_version(format_version);
  log.set_dt_s(dt_s);
  log.set_sample_count(samples.size());
  log.set_encoded(EncodeInputSamples(samples, format_version));
  log.set_encoding(std::string(InputLogEncodingOf(format_version)));
  return log;
}

std::vector<InputSample> DecodeInputLog(const v1::InputLog& log) {
  const std::string_view encoding = InputLogEncodingOf(log.format_version());
  if (encoding.empty() || log.encoding() != encoding) {
    throw InputLogError("input log: unsupported format " + std::to_string(log.format_version()) +
                        " encoding '" + log.encoding() +
                        "' (expected 1 delta-zlib-v1 or 2 delta-zlib-v2)");
  }
  const std::uint32_t in_data = PeekInputLogFormatVersion(log.encoded());
  if (in_data != log.format_version()) {
    throw InputLogError("input log: format_version " + std::to_string(log.format_version()) +
                        " but the encoded data is version " + std::to_string(in_data));
  }
  if (!(log.dt_s() > 0.0 && log.dt_s() < 1.0)) {
    throw InputLogError("input log: dt_s must be in (0, 1) s, got " + std::to_string(log.dt_s()));
  }
  std::vector<InputSample> samples = DecodeInputSamples(log.encoded());
  if (samples.size() != log.sample_count()) {
    throw InputLogError("input log: sample_count " + std::to_string(log.sample_count()) +
                        " but the data holds " + std::to_string(samples.size()));
  }
  return samples;
}

}  // namespace ves::training
