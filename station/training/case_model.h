#pragma once

#include <string>

#include "station/model/model.h"
#include "ves/v1/case.pb.h"
#include "ves/v1/endoscope.pb.h"

// Turns a colon case and an endoscope spec (protos) into the model's plain
// spec structs (DESIGN.md §1: training depends on model and proto).
namespace ves::training {

struct CaseModelOptions {
  int segments{150};         // N, the paper's 150 by default
  bool stiff_colon{false};   // every suspension stiff: the older model (paper §3.6)
};

// Resamples the case's centerline into options.segments points with R = phi(s),
// regions and tissue. Throws std::invalid_argument naming the bad value.
ves::model::ColonSpec ColonSpecFromCase(const ves::v1::ColonCase& colon_case,
                                        const CaseModelOptions& options = {});

// A field left at 0 takes the model's default (station/model/endoscope.h), so a
// scope file may give only what differs. Throws std::invalid_argument.
ves::model::EndoscopeParams EndoscopeFromSpec(const ves::v1::EndoscopeSpec& spec);

// The region of the colon at arc length `arc_m` (the segment point at or
// before it) as the case format names it: "rectum", "sigmoid",
// "splenic-flexure", ...; "unspecified" for an empty colon.
std::string RegionNameAt(const ves::model::ColonSpec& colon, double arc_m);

// The default adult colonoscope as a spec (docs/model.md lists the sources).
ves::v1::EndoscopeSpec DefaultEndoscopeSpec();

// Colon + scope + defaults; validated (throws std::invalid_argument).
ves::model::ModelParams MakeModelParams(const ves::v1::ColonCase& colon_case,
                                        const ves::v1::EndoscopeSpec& scope,
                                        const CaseModelOptions& options = {});

}  // namespace ves::training
