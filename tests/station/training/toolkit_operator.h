#pragma once

#include <cstdint>

#include "station/training/scripted_operator.h"

namespace ves::training {

// The scripted novice with the loop-control toolkit on a timetable (model
// steps): the assistant presses the left lower quadrant over steps
// [300, 800) and mid-abdomen over [1000, 1300); the patient lies left
// lateral from step 500, right lateral from 1200 and supine again from 1600:
// three turns.
class ToolkitNovice final : public ScriptedOperator {
 public:
  InputSample Act(const Perception& perception) override {
    InputSample in = novice_.Act(perception);
    const std::uint64_t k = step_++;
    if (k >= 300 && k < 800) in.abdominal_press = AbdominalPress::kLeftLowerQuadrant;
    if (k >= 1000 && k < 1300) in.abdominal_press = AbdominalPress::kMidAbdomen;
    if (k >= 500 && k < 1200) in.patient_position = PatientPosition::kLeftLateral;
    if (k >= 1200 && k < 1600) in.patient_position = PatientPosition::kRightLateral;
    return in;
  }

 private:
  NoviceOperator novice_;
  std::uint64_t step_{0};
};

}  // namespace ves::training
