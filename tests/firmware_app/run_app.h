// Starting qsg_app from a test (QSG_APP_PATH, set by tests/firmware_app/CMakeLists.txt). Tests that call it skip
// under qemu-user (tests/support/emulation.h).
#pragma once

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace qsg::app::testing {

// Runs qsg_app with `args`; its exit status (-1 if it did not exit normally: a signal such as SIGABRT; -2 if it
// could not be started) and what it printed on stdout and stderr (both go to log_path).
inline int run_app(const std::vector<std::string>& args, const std::string& log_path, std::string* output) {
  std::vector<std::string> all = {QSG_APP_PATH};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  const int spawned = ::posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return -2;
  int status = 0;
  ::waitpid(pid, &status, 0);
  std::ifstream in(log_path);
  std::stringstream text;
  text << in.rdbuf();
  *output = text.str();
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace qsg::app::testing
