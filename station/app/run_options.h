#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "station/app/run_lesson.h"
#include "station/sync/server_client.h"

// What `ves-station run` was asked to do: run_command.cc reads it from the
// command line; the headless run, the interactive sitting and the outbox
// commit read it (docs/station-run.md).
namespace ves::station {

// The prefix of the run's messages, and its exit status (commands.h).
inline constexpr char kRunName[] = "ves-station run";
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailed = 1;
inline constexpr int kExitUsage = 2;

struct RunOptions {
  std::optional<sync::ServerEndpoint> server;
  std::string trainee_id;
  std::string case_id;
  std::string lesson;  // "next": run the trainee's next lesson (docs/lessons.md)
  bool seconds_given{false};
  double verdict_wait_s{30.0};
  std::optional<LessonPlan> lesson_plan;  // set by Run when --lesson
  std::string scope_path;
  std::string data_dir;
  std::string station_id;
  bool headless{false};
  std::string operator_kind;
  std::string can_interface;  // empty: the simulated device
  std::string can_log;
  std::string gamepad;  // evdev device of a game controller; empty: none
  std::filesystem::path out_dir;
  double seconds{600.0};
  double frame_period_s{5.0};
  int upload_attempts{3};
  bool live{true};       // with a server: stream the session (docs/station-run.md)
  bool realtime{false};  // headless: simulated time no faster than the wall clock
};

}  // namespace ves::station
