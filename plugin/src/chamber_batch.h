// The linearized chamber step (LinearizedPressureStep) for many chambers at once: the
// chambers of every cylinder a forward pass steps, four at a time in the vector lanes of
// AVX2 (the scalar step, one by one, on a processor without it). Each lane does exactly the
// arithmetic of LinearizedPressureStep for one chamber on its own, so a chamber's result is
// the same, bit for bit, whether it is stepped here or alone (tests/chamber_batch_test),
// and does not depend on the chambers beside it.
#ifndef PNEUMATIC_CHAMBER_BATCH_H_
#define PNEUMATIC_CHAMBER_BATCH_H_

#include "chamber.h"

namespace pneumatic {

// One chamber's step: what it reads, and what it writes (p1, done).
struct BatchedChamber {
  const ChamberModel* model = nullptr;  // must satisfy Batchable
  PortOpenings open_start, open_end;    // valve openings at the start and the end of the step
  bool held = true;                     // no valve switching within the step (else done = false)
  VolumePath volume;                    // the chamber's volume over the step
  double p0 = 0;                        // Pa abs, at the start of the step
  double p1 = 0;                        // Pa abs, at the end: set where done
  bool done = false;                    // false: the adaptive PhysicalPressureStep must take over
};

// true if the chamber's model is one the batch steps: thin-plate flow (paper 000 eq. 1) and no orifice
// leak to the atmosphere (the laminar leak is taken); a chamber on its own (no leak across the piston)
bool Batchable(const ChamberModel& k);

// LinearizedPressureStep(1, ...) for each of chambers[0, count), with the timestep h (s): in vector
// lanes where the processor has AVX2, else one by one
void LinearizedChambers(BatchedChamber chambers[], int count, double h);
// the same, in lanes or one by one as asked (lanes only where VectorLanesAvailable(): the build has
// them, CMake option PNEUMATIC_VECTOR_LANES, and the processor has AVX2; else one by one)
bool VectorLanesAvailable();
void LinearizedChambers(BatchedChamber chambers[], int count, double h, bool in_lanes);

}  // namespace pneumatic

#endif  // PNEUMATIC_CHAMBER_BATCH_H_
