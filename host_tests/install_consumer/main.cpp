// Uses both exported targets: the header-only core and the identify library.
#include <kincal/core/reference_machines.hpp>
#include <kincal/identify/robot.hpp>

int main() {
  const auto g = kincal::make_stewart_seed001<float>();
  kincal::Vec6<float> q;
  if (kincal::stewart_ik(g, g.home, q) != kincal::Status::Ok) return 1;
  const kincal::identify::Robot r = kincal::identify::load_robot("hybrid-seed000");
  return r.joint_count() == 6 ? 0 : 2;
}
