// explain --propose-plan (calib/explain_propose.h, issue 27 item 1): the proposed plan for what
// a recording could not separate, checked by explaining a simulated recording of it.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <iostream>

#include "calib/explain_propose.h"
#include "explain_sim.h"
#include "io/plan_writer.h"
#include "plans/proposal.h"
#include "plans/validator.h"

namespace imubench::calib::testing {
namespace {

constexpr double kArcsec = kPi / 180.0 / 3600.0;

void printProposal(const ProposeResult& p) {
  std::cout << "proposal: " << p.status.message << " duration " << p.duration_s << " s\n";
  for (const ProposedGroup& g : p.groups) {
    std::cout << "  group";
    for (const std::string& e : g.effects) std::cout << " " << e;
    std::cout << (g.resolved ? " resolved" : " UNRESOLVED: " + g.why) << ", angle "
              << g.angle_before_rad / kPi * 180 << " -> " << g.angle_after_rad / kPi * 180
              << " deg, adds " << g.added.size() << " blocks " << g.added_duration_s << " s\n";
    for (std::size_t k = 0; k < g.flat_names.size(); ++k) {
      std::cout << "    " << g.flat_names[k] << " sigma " << g.sigma_before[k] << " -> "
                << g.sigma_after[k] << "\n";
    }
  }
  for (const std::string& n : p.notes) std::cout << "  note: " << n << "\n";
}

[[maybe_unused]] const ExplainAccepted* accepted(const ExplainResult& r, const std::string& id) {
  for (const ExplainAccepted& a : r.accepted) {
    if (a.effect == id) return &a;
  }
  return nullptr;
}

EffectSet concealedNonorthogonalityAndZero() {
  EffectSet e;
  e.enable(EffectId::kNonorthogonality);
  e.nonorthogonality->inner_y = 30.0 * kArcsec;
  e.enable(EffectId::kEncoderZero);
  e.encoder_zero->inner = 25.0 * kArcsec;
  return e;
}

TEST(ExplainPropose, Explore) {
  const EffectSet e = concealedNonorthogonalityAndZero();
  const SimulatedRecording rec = simulateWith(libraryMotion("direct_two_axis"), e, 21);
  const ExplainInput input = simulatedExplainInput(rec);
  const ExplainResult r = explainRecording(input);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  std::cout << summary(r);
  const auto t0 = std::chrono::steady_clock::now();
  const ProposeResult p =
      proposePlan(input, r, ExplainOptions{}, ProposeOptions{}, plans::expandProposedPlan);
  std::cout << "took " << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()
            << " s\n";
  ASSERT_TRUE(p.status.ok) << p.status.message;
  printProposal(p);
  std::cout << io::proposedPlanToml(p.plan).substr(0, 3000);
}

}  // namespace
}  // namespace imubench::calib::testing
