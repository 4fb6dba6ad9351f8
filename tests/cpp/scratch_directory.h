// A fixture giving each test an empty directory of its own, removed afterwards.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace penumbra::test {

class ScratchDirectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::UnitTest& run = *::testing::UnitTest::GetInstance();
    directory_ = std::filesystem::temp_directory_path() /
                 ("penumbra-" + std::string(run.current_test_info()->test_suite_name()) + "-" +
                  std::to_string(run.random_seed()) + "-" + run.current_test_info()->name());
    std::filesystem::remove_all(directory_);
    std::filesystem::create_directories(directory_);
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }
  std::string path(const std::string& name) const { return (directory_ / name).string(); }

  std::filesystem::path directory_;
};

}  // namespace penumbra::test
