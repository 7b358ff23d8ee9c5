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

TEST(InputLog, TenMinutesAtOneKilohertzIsWellUnderFiveMegabytes) {
  const auto samples = HumanLikeSamples(600000, 2);
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
    if (trial % 2 == 0 && garbage.size() >= 4) garbage.replace(0, 4, "VIL1");
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

TEST(InputLog, EmptyLogRoundTrips) {
  EXPECT_TRUE(DecodeInputSamples(EncodeInputSamples({})).empty());
}

}  // namespace
}  // namespace ves::training
