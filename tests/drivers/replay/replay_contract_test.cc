// The RGB-D source contract on every replay backend: TUM (written by TumWriter, with a missing frame), Redwood
// (the real frames in tests/data), ICL-NUIM pose list (shared data, skipped when absent), and the fault decorator
// over a replay.
#include <memory>

#include "drivers/replay/pose_list_replay.h"
#include "drivers/replay/redwood_replay.h"
#include "drivers/replay/tum_replay.h"
#include "tests/drivers/replay/replay_test_util.h"
#include "tests/drivers/rgbd_source_contract.h"
#include "tests/support/test_data.h"

namespace qsg::testing {
namespace {

// Six 64x48 frames written once per process; frame 3's depth image is deleted so replay must skip it.
const std::string& tum_dataset() {
  static const std::string dir = [] {
    const std::string d = fresh_dir("contract_tum");
    auto frame = std::make_unique<messages::RgbdFrame>();
    replay::TumWriter writer;
    std::string error;
    writer.open(d, replay::TumWriter::Config{}, &error);
    for (int i = 0; i < 6; ++i) {
      fill_synthetic_frame(*frame, 64, 48, i, 2'000'000'000LL + i * 50'000'000LL, i % 2 == 0);
      writer.write_frame(*frame, &error);
    }
    writer.close(&error);
    std::remove((d + "/depth/2.150000.png").c_str());
    return d;
  }();
  return dir;
}

std::shared_ptr<drivers::RgbdSource> make_tum(std::string* reason) {
  auto source = std::make_shared<replay::TumReplay>();
  replay::TumReplay::Config config;
  config.check_files_at_open = false;
  if (!source->open(tum_dataset(), config, reason)) return nullptr;
  return source;
}

std::shared_ptr<drivers::RgbdSource> make_redwood(std::string* reason) {
  auto source = std::make_shared<replay::RedwoodReplay>();
  replay::RedwoodReplay::Config config;
  config.camera_json = "../camera_primesense.json";
  if (!source->open(repo_test_data("rgbd/redwood/RGBD"), config, reason)) return nullptr;
  return source;
}

std::shared_ptr<drivers::RgbdSource> make_icl(std::string* reason) {
  const std::string pose = shared_data_file("rgbd/icl_nuim_livingroom5/pose.txt");
  if (pose.empty()) {
    *reason = "shared data rgbd/icl_nuim_livingroom5 not found";
    return nullptr;
  }
  auto source = std::make_shared<replay::PoseListReplay>();
  replay::PoseListReplay::Config config;
  config.intrinsics.fx = 481.2;
  config.intrinsics.fy = -480.0;
  if (!source->open(pose.substr(0, pose.size() - 9), config, reason)) return nullptr;
  return source;
}

}  // namespace

INSTANTIATE_TEST_SUITE_P(Replay, RgbdSourceContract,
                         ::testing::Values(RgbdContractCase{"tum", make_tum, true, 50, true},
                                           RgbdContractCase{"redwood", make_redwood, true, 50, true},
                                           RgbdContractCase{"icl_nuim_pose_list", make_icl, true, 50, true}),
                         rgbd_contract_case_name);

}  // namespace qsg::testing
