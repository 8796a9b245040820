// The segments a calibrator uses, checked against the encoders (pure): recordings made by
// other programs split a hold into a short "settle" and the hold proper, or mark a span static
// while the table still turns. Here
//   - adjacent static segments at the same encoder angles become one hold (so a rotation run
//     finds its hold across such a split, and the hold averages all its data);
//   - a static segment inside which the encoders move contradicts them: it is named and
//     dropped (its mean would mix attitudes);
//   - a rotate segment inside which no axis turns contradicts them: it is named (the
//     calibrators skip it with their own note).
// Kinds other than static and rotate pass through unchanged.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "calib/model/motion.h"
#include "calib/simulator.h"

namespace imubench::calib {

struct SegmentCheckOptions {
  // Two static segments are one hold when the gap between them is at most this (s): loggers
  // write the boundary of a split hold once or with a sample period between.
  double adjacency_s = 0.5;
  // ... and their mean encoder angles agree within this (rad, ~20 arcsec): a split hold reads
  // the same angles, a new position differs by degrees.
  double same_angle_rad = 1e-4;
  // A static segment whose encoder angles span more than this (rad, 0.01 deg) moves: servo
  // dither and encoder jitter at rest stay well below it.
  double still_span_rad = 1.75e-4;

  bool IsValid(std::string* why) const;
};

struct SegmentCheckResult {
  std::vector<Segment> segments;   // merged and checked, in time order
  int merged = 0;                  // static segments joined into the hold before them
  std::vector<std::string> notes;  // merges (one summary) and contradictions, by label and time
  std::vector<std::string> contradictions;  // segments that contradict the encoders
};

SegmentCheckResult checkSegments(TableKind kind, std::span<const TableSample> table,
                                 std::span<const Segment> segments,
                                 const SegmentCheckOptions& options = {});

}  // namespace imubench::calib
