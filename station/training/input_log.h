#pragma once

#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "station/model/model.h"
#include "station/training/observation.h"
#include "ves/v1/session.pb.h"

namespace ves::training {

// How the operator drives insertion: by position (encoder, spring mode) or by
// the hand's force (free/coupled mode), paper §2.2. The model's own enum; the
// log stores its number (kPosition 0, kForce 1, checked in input_log.cc).
using ThrustMode = model::ThrustMode;

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
  // The loop-control toolkit (format version 2): the assistant's hand on the
  // abdomen and the patient's position, as the trainee asked for them.
  AbdominalPress abdominal_press{AbdominalPress::kNone};
  PatientPosition patient_position{PatientPosition::kSupine};

  bool operator==(const InputSample&) const = default;
};

// Resolution of the log (docs/scoring.md, "Input log").
inline constexpr double kLogLengthResolution_m = 1e-6;
inline constexpr double kLogForceResolution_N = 1e-4;
inline constexpr double kLogAngleResolution_rad = 1e-6;
// What MakeInputLog writes. Version 2 added the abdominal press and the
// patient's position; version 1 logs (without them) still decode, the two
// at their defaults (no press, supine), and replay as they always did.
inline constexpr char kInputLogEncoding[] = "delta-zlib-v2";
inline constexpr std::uint32_t kInputLogFormatVersion = 2;

// The encoding name of a format version the decoder reads ("delta-zlib-v1"
// for 1, "delta-zlib-v2" for 2); empty for any other.
std::string_view InputLogEncodingOf(std::uint32_t format_version);

// Rounds a sample to the log's resolution. Throws std::invalid_argument
// naming the field when a value is not finite or out of range.
InputSample Quantize(const InputSample& sample);

// Refusal of a log that is truncated, corrupted or of an unknown format.
class InputLogError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Column-wise delta coding (zig-zag varints) of the quantized samples,
// zlib-compressed behind a header with the format's magic ("VIL1", "VIL2"),
// the sample count, raw length and the CRC-32 of the raw bytes. Pure
// functions. Writes the current format; format_version 1 writes the old
// one (as stations before version 2 did, for tests of old logs) and throws
// std::invalid_argument for a sample that uses a field it lacks.
std::string EncodeInputSamples(std::span<const InputSample> samples,
                               std::uint32_t format_version = kInputLogFormatVersion);
// Reads either format (the magic says which). Throws InputLogError when
// anything does not check out; never reads out of bounds.
std::vector<InputSample> DecodeInputSamples(std::string_view encoded);
// The format version of an encoded log's magic; InputLogError for a
// truncated header or a bad magic.
std::uint32_t PeekInputLogFormatVersion(std::string_view encoded);

// The sample count the header of an encoded log claims, read without
// decompressing anything, so a caller can refuse a log before decoding it.
// Throws InputLogError for a truncated header or a bad magic.
std::uint64_t PeekInputSampleCount(std::string_view encoded);

// Most samples a session with this time limit and step can log (one per step
// until the limit); 0 for a non-positive limit or step.
std::uint64_t MaxSessionSamples(double time_limit_s, double dt_s);

v1::InputLog MakeInputLog(std::span<const InputSample> samples, double dt_s,
                          std::uint32_t format_version = kInputLogFormatVersion);
// Checks format_version and encoding (a version the decoder reads, its
// encoding name, the encoded data's magic), dt_s and sample_count against
// the data.
std::vector<InputSample> DecodeInputLog(const v1::InputLog& log);

}  // namespace ves::training
