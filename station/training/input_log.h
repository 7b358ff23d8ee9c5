#pragma once

#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "station/training/observation.h"
#include "ves/v1/session.pb.h"

namespace ves::training {

// How the operator drives insertion: by position (encoder, spring mode) or by
// the hand's force (free/coupled mode), paper §2.2.
enum class ThrustMode : std::uint8_t { kPosition = 0, kForce = 1 };

// What the operator did during one model step: everything replay needs to
// re-run the model (DESIGN.md §5). Values are held at the log's resolution
// (Quantize) so the live run and its replay feed the model identical numbers.
struct InputSample {
  std::uint64_t tick{0};  // model step index; time = tick * dt_s
  ThrustMode thrust_mode{ThrustMode::kForce};
  double insertion_m{0.0};   // used in kPosition
  double push_force_N{0.0};  // used in kForce
  double roll_rad{0.0};
  double knob_up_rad{0.0};     // as model::StepInput: + up, - down
  double knob_right_rad{0.0};  // + right, - left
  ViewMode view_mode{ViewMode::kTextured};
  bool fluoroscopy_on{false};

  bool operator==(const InputSample&) const = default;
};

// Resolution of the log (docs/scoring.md, "Input log").
inline constexpr double kLogLengthResolution_m = 1e-6;
inline constexpr double kLogForceResolution_N = 1e-4;
inline constexpr double kLogAngleResolution_rad = 1e-6;
inline constexpr char kInputLogEncoding[] = "delta-zlib-v1";
inline constexpr std::uint32_t kInputLogFormatVersion = 1;

// Rounds a sample to the log's resolution. Throws std::invalid_argument
// naming the field when a value is not finite or out of range.
InputSample Quantize(const InputSample& sample);

// Refusal of a log that is truncated, corrupted or of an unknown format.
class InputLogError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Column-wise delta coding (zig-zag varints) of the quantized samples,
// zlib-compressed behind a header with the sample count, raw length and the
// CRC-32 of the raw bytes. Pure functions.
std::string EncodeInputSamples(std::span<const InputSample> samples);
// Throws InputLogError when anything does not check out; never reads out of bounds.
std::vector<InputSample> DecodeInputSamples(std::string_view encoded);

// The sample count the header of an encoded log claims, read without
// decompressing anything, so a caller can refuse a log before decoding it.
// Throws InputLogError for a truncated header or a bad magic.
std::uint64_t PeekInputSampleCount(std::string_view encoded);

// Most samples a session with this time limit and step can log (one per step
// until the limit); 0 for a non-positive limit or step.
std::uint64_t MaxSessionSamples(double time_limit_s, double dt_s);

v1::InputLog MakeInputLog(std::span<const InputSample> samples, double dt_s);
// Checks format_version, encoding, dt_s and sample_count against the data.
std::vector<InputSample> DecodeInputLog(const v1::InputLog& log);

}  // namespace ves::training
