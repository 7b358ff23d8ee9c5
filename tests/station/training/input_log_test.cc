#include "station/training/input_log.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace ves::training {
namespace {

// A person's hands at 1 kHz: a slowly varying push with sensor noise, a
// drifting roll, knobs moved now and then, a view switch and fluoroscopy
// toggled every ~20 s.
std::vector<InputSample> HumanLikeSamples(std::size_t count, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise_N(0.0, 0.02);
  std::normal_distribution<double> drift(0.0, 1e-4);
  std::vector<InputSample> samples(count);
  double roll_rad = 0.0;
  double knob_rad = 0.0;
  for (std::size_t i = 0; i < count; ++i) {
    InputSample& s = samples[i];
    const double t_s = static_cast<double>(i) * 1e-3;
    s.tick = i;
    s.thrust_mode = ThrustMode::kForce;
    s.push_force_N = 2.0 + std::sin(0.5 * t_s) + noise_N(rng);
    s.insertion_m = 0.001 * t_s;
    roll_rad += drift(rng);
    s.roll_rad = roll_rad;
    if (i % 500 == 0) knob_rad = std::uniform_real_distribution<double>(-1.0, 1.0)(rng);
    s.knob_up_rad = knob_rad;
    s.knob_right_rad = -0.5 * knob_rad;
    s.view_mode = (i / 100000) % 2 == 0 ? ViewMode::kTextured : ViewMode::kWireframe;
    s.fluoroscopy_on = (i / 20000) % 2 == 1;
  }
  return samples;
}

// The same hands with the loop-control toolkit: the assistant presses for
// 15 s of every minute (left lower quadrant, then mid-abdomen), and the
// patient turns every two and a half minutes.
std::vector<InputSample> HumanLikeSamplesWithToolkit(std::size_t count, std::uint32_t seed) {
  std::vector<InputSample> samples = HumanLikeSamples(count, seed);
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t minute = i / 60000;
    if (i % 60000 >= 30000 && i % 60000 < 45000) {
      samples[i].abdominal_press =
          minute % 2 == 0 ? AbdominalPress::kLeftLowerQuadrant : AbdominalPress::kMidAbdomen;
    }
    samples[i].patient_position = static_cast<PatientPosition>((i / 150000) % 3);
  }
  return samples;
}

// A few samples that use every column of format version 1, and the bytes
// the version 1 encoder (before the abdominal press and the patient's
// position existed, commit e007879) wrote for them.
std::vector<InputSample> Version1FixtureSamples() {
  std::vector<InputSample> samples(12);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    InputSample& s = samples[i];
    const double k = static_cast<double>(i);
    s.tick = i;
    s.thrust_mode = i < 6 ? ThrustMode::kForce : ThrustMode::kPosition;
    s.insertion_m = 0.25 + 0.0013 * k;
    s.push_force_N = 3.5 - 0.75 * k;
    s.roll_rad = -0.1 + 0.02 * k;
    s.knob_up_rad = i % 4 == 0 ? 0.5 : -0.25;
    s.knob_right_rad = 0.001 * k * k;
    s.view_mode = static_cast<ViewMode>(i % 3);
    s.fluoroscopy_on = i % 5 == 1;
  }
  return samples;
}
constexpr char kVersion1FixtureHex[] =
    "56494c310c00000000000000bc00000035ccaea7643d9df278da636042020c20c00826171c925b21820d7e58"
    "c432bd141bdc3f8be7c00e2602a8c5f6feb168068607c7a25168860bfc1ff426f86dc8bdd0c3f86135e384d3"
    "8c1b5e315ee864fab08269c209260626266618626002b90f42000035594246";

std::string FromHex(std::string_view hex) {
  std::string bytes;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) {
    bytes.push_back(static_cast<char>(std::stoi(std::string(hex.substr(i, 2)), nullptr, 16)));
  }
  return bytes;
}

std::vector<InputSample> Quantized(const std::vector<InputSample>& samples) {
  std::vector<InputSample> out;
  for (const auto& s : samples) out.push_back(Quantize(s));
  return out;
}

TEST(InputLog, RoundTripGivesTheQuantizedSamplesExactly) {
  const auto samples = HumanLikeSamples(5000, 1);
  const auto decoded = DecodeInputSamples(EncodeInputSamples(samples));
  EXPECT_EQ(decoded, Quantized(samples));
}

TEST(InputLog, QuantizeRoundsToTheLogResolution) {
  InputSample s;
  s.insertion_m = 0.1234567;  // 1 um resolution
  s.push_force_N = 1.23456;   // 0.1 mN
  const InputSample q = Quantize(s);
  EXPECT_NEAR(q.insertion_m, 0.123457, 1e-12);
  EXPECT_NEAR(q.push_force_N, 1.2346, 1e-12);
  EXPECT_EQ(Quantize(q), q);  // idempotent: the live run and the replay see the same values
}

TEST(InputLog, NonFiniteInputIsRefusedNamingTheField) {
  InputSample s;
  s.roll_rad = std::nan("");
  try {
    Quantize(s);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("roll_rad"), std::string::npos) << e.what();
  }
}

TEST(InputLog, RoundTripCarriesThePressAndThePosition) {
  const auto samples = HumanLikeSamplesWithToolkit(320000, 1);
  const auto decoded = DecodeInputSamples(EncodeInputSamples(samples));
  EXPECT_EQ(decoded, Quantized(samples));
  int pressed = 0;
  int turned = 0;
  for (const InputSample& s : decoded) {
    pressed += s.abdominal_press != AbdominalPress::kNone;
    turned += s.patient_position != PatientPosition::kSupine;
  }
  EXPECT_EQ(pressed, 5 * 15000);  // the sixth minute ends before its press
  EXPECT_EQ(turned, 150000 + 20000);
}

TEST(InputLog, Version1LogsStillDecodeWithTheToolkitAtItsDefaults) {
  const std::string stored = FromHex(kVersion1FixtureHex);
  ASSERT_EQ(PeekInputLogFormatVersion(stored), 1u);
  const auto decoded = DecodeInputSamples(stored);
  EXPECT_EQ(decoded, Quantized(Version1FixtureSamples()));
  for (const InputSample& s : decoded) {
    EXPECT_EQ(s.abdominal_press, AbdominalPress::kNone);
    EXPECT_EQ(s.patient_position, PatientPosition::kSupine);
  }
  // Format 1 is still written byte for byte as it was.
  EXPECT_EQ(EncodeInputSamples(Version1FixtureSamples(), 1), stored);
  // And the current format is another one, holding the same samples.
  const std::string current = EncodeInputSamples(Version1FixtureSamples());
  EXPECT_EQ(PeekInputLogFormatVersion(current), kInputLogFormatVersion);
  EXPECT_NE(current, stored);
  EXPECT_EQ(DecodeInputSamples(current), decoded);
}

TEST(InputLog, Version1CannotHoldThePressOrThePosition) {
  auto samples = Version1FixtureSamples();
  samples[3].abdominal_press = AbdominalPress::kMidAbdomen;
  EXPECT_THROW(EncodeInputSamples(samples, 1), std::invalid_argument);
  samples[3].abdominal_press = AbdominalPress::kNone;
  samples[7].patient_position = PatientPosition::kLeftLateral;
  EXPECT_THROW(EncodeInputSamples(samples, 1), std::invalid_argument);
  EXPECT_THROW(EncodeInputSamples(samples, 3), std::invalid_argument);
}

TEST(InputLog, AnUnknownPressOrPositionIsRefusedNamingTheField) {
  for (const char* field : {"abdominal_press", "patient_position"}) {
    auto samples = Version1FixtureSamples();
    if (std::string(field) == "abdominal_press") {
      samples[5].abdominal_press = static_cast<AbdominalPress>(3);
    } else {
      samples[5].patient_position = static_cast<PatientPosition>(7);
    }
    const std::string encoded = EncodeInputSamples(samples);
    try {
      DecodeInputSamples(encoded);
      ADD_FAILURE() << field << ": expected InputLogError";
    } catch (const InputLogError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
}

TEST(InputLog, TenMinutesAtOneKilohertzIsWellUnderFiveMegabytes) {
  const auto samples = HumanLikeSamplesWithToolkit(600000, 2);
  const std::string encoded = EncodeInputSamples(samples);
  std::printf("10 min at 1 kHz: %zu bytes (%.2f bytes/sample)\n", encoded.size(),
              static_cast<double>(encoded.size()) / samples.size());
  EXPECT_LT(encoded.size(), 2'500'000u);  // half the 5 MB budget
  EXPECT_EQ(DecodeInputSamples(encoded).size(), samples.size());
}

TEST(InputLog, EveryTruncationIsRefused) {
  const std::string encoded = EncodeInputSamples(HumanLikeSamples(2000, 3));
  for (std::size_t length = 0; length < encoded.size(); ++length) {
    EXPECT_THROW(DecodeInputSamples(std::string_view(encoded).substr(0, length)), InputLogError)
        << "length " << length;
  }
}

TEST(InputLog, RandomByteFlipsAreRefusedNeverCrash) {
  const std::string encoded = EncodeInputSamples(HumanLikeSamples(2000, 4));
  std::mt19937 rng(5);
  std::uniform_int_distribution<std::size_t> where(0, encoded.size() - 1);
  std::uniform_int_distribution<int> flip(1, 255);
  for (int trial = 0; trial < 3000; ++trial) {
    std::string corrupted = encoded;
    const int flips = 1 + trial % 3;
    for (int f = 0; f < flips; ++f) corrupted[where(rng)] ^= static_cast<char>(flip(rng));
    EXPECT_THROW(DecodeInputSamples(corrupted), InputLogError) << "trial " << trial;
  }
}

TEST(InputLog, RandomGarbageIsRefused) {
  std::mt19937 rng(6);
  for (int trial = 0; trial < 500; ++trial) {
    std::string garbage(std::uniform_int_distribution<int>(0, 300)(rng), '\0');
    for (char& c : garbage) c = static_cast<char>(rng());
    if (trial % 2 == 0 && garbage.size() >= 4) garbage.replace(0, 4, trial % 4 ? "VIL1" : "VIL2");
    EXPECT_THROW(DecodeInputSamples(garbage), InputLogError);
  }
}

TEST(InputLog, ProtoLogChecksEncodingAndCount) {
  const auto samples = HumanLikeSamples(100, 7);
  v1::InputLog log = MakeInputLog(samples, 0.001);
  EXPECT_EQ(log.sample_count(), 100u);
  EXPECT_EQ(DecodeInputLog(log), Quantized(samples));
  v1::InputLog wrong_count = log;
  wrong_count.set_sample_count(99);
  EXPECT_THROW(DecodeInputLog(wrong_count), InputLogError);
  v1::InputLog wrong_encoding = log;
  wrong_encoding.set_encoding("gzip");
  EXPECT_THROW(DecodeInputLog(wrong_encoding), InputLogError);
  v1::InputLog wrong_dt = log;
  wrong_dt.set_dt_s(0.0);
  EXPECT_THROW(DecodeInputLog(wrong_dt), InputLogError);
}

TEST(InputLog, ProtoLogOfEitherVersionDecodesWhenItsDataIsThatVersion) {
  const auto samples = HumanLikeSamples(100, 8);
  const v1::InputLog current = MakeInputLog(samples, 0.001);
  EXPECT_EQ(current.format_version(), 2u);
  EXPECT_EQ(current.encoding(), "delta-zlib-v2");
  const v1::InputLog old = MakeInputLog(samples, 0.001, 1);
  EXPECT_EQ(old.format_version(), 1u);
  EXPECT_EQ(old.encoding(), "delta-zlib-v1");
  EXPECT_EQ(DecodeInputLog(old), DecodeInputLog(current));
  // The version the record states, its encoding name and the data's magic agree.
  v1::InputLog mixed = old;
  mixed.set_encoded(current.encoded());
  EXPECT_THROW(DecodeInputLog(mixed), InputLogError);
  mixed = current;
  mixed.set_encoding("delta-zlib-v1");
  EXPECT_THROW(DecodeInputLog(mixed), InputLogError);
  mixed = current;
  mixed.set_format_version(3);
  mixed.set_encoding("delta-zlib-v3");
  EXPECT_THROW(DecodeInputLog(mixed), InputLogError);
}

TEST(InputLog, EmptyLogRoundTrips) {
  EXPECT_TRUE(DecodeInputSamples(EncodeInputSamples({})).empty());
}

}  // namespace
}  // namespace ves::training
