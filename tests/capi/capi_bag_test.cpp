// ROS bags through the C API: a bag written by ROS's own Python tools, read with the defaults
// and with chosen options, and the errors a wrong choice gives.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "capi_test_support.hpp"

#ifdef POTMAP_WITH_ROS

namespace {

using namespace capi_test;

std::string intel_bag() {
  const std::string out = temp_dir("capi_bag") + "/intel.bag";
  const std::string cmd = std::string(POTMAP_DEBIAN_PYTHON) + " '" + POTMAP_SOURCE_DIR +
                          "/tests/data/write_ros1_bag.py' carmen '" +
                          shared_data("radish/intel-corrected.log.gz") + "' --scans 12 '" + out +
                          "'";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return out;
}

size_t count(potmap_dataset* d) {
  size_t n = 0;
  EXPECT_EQ(potmap_dataset_size(d, &n), POTMAP_SUCCESS);
  return n;
}

TEST(CApiBag, ReadsWithTheDefaultsAndWithChosenOptions) {
  const std::string bag = intel_bag();
  potmap_dataset* plain = nullptr;
  POTMAP_ASSERT_OK(potmap_dataset_load(bag.c_str(), &plain));
  EXPECT_EQ(count(plain), 12u);

  potmap_bag_options o;
  POTMAP_ASSERT_OK(potmap_bag_options_init(&o, sizeof o));
  EXPECT_EQ(o.keyframe_distance, 1.0);
  EXPECT_EQ(o.topic, nullptr);
  o.topic = "/scan";
  o.pose_topic = "/odom";
  potmap_dataset* chosen = nullptr;
  POTMAP_ASSERT_OK(potmap_dataset_load_bag(bag.c_str(), &o, &chosen));
  ASSERT_EQ(count(chosen), 12u);
  // /tf and /odom carry the same poses: the same scans either way.
  for (size_t i = 0; i < 12; ++i) {
    potmap_scan a, b;
    POTMAP_ASSERT_OK(potmap_scan_init(&a, sizeof a));
    POTMAP_ASSERT_OK(potmap_scan_init(&b, sizeof b));
    POTMAP_ASSERT_OK(potmap_dataset_scan(plain, i, &a));
    POTMAP_ASSERT_OK(potmap_dataset_scan(chosen, i, &b));
    ASSERT_EQ(a.num_hits, b.num_hits);
    for (size_t k = 0; k < 2 * a.num_hits; ++k) EXPECT_NEAR(a.hits[k], b.hits[k], 1e-9);
  }
  potmap_dataset_destroy(plain);
  potmap_dataset_destroy(chosen);
}

TEST(CApiBag, AWrongTopicOrOptionNamesIt) {
  const std::string bag = intel_bag();
  potmap_bag_options o;
  POTMAP_ASSERT_OK(potmap_bag_options_init(&o, sizeof o));
  o.topic = "/points";
  potmap_dataset* d = nullptr;
  POTMAP_EXPECT_FAIL(potmap_dataset_load_bag(bag.c_str(), &o, &d), POTMAP_ERROR_INPUT);
  EXPECT_TRUE(contains(potmap_last_error(), "no topic /points")) << potmap_last_error();
  EXPECT_TRUE(contains(potmap_last_error(), bag)) << potmap_last_error();
  EXPECT_EQ(d, nullptr);
  POTMAP_ASSERT_OK(potmap_bag_options_init(&o, sizeof o));
  o.keyframe_distance = -1;
  POTMAP_EXPECT_FAIL(potmap_dataset_load_bag(bag.c_str(), &o, &d), POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "keyframe_distance")) << potmap_last_error();
}

}  // namespace

#endif
