// outbox_commit_probe DB LOG: commits one record to the outbox at DB, writing
// "commit begins" and "commit returned" to LOG around the call (the fsync
// spy appends to the same LOG), for Outbox.ACommitIsOnDiskFileAndFolder.
#include <fstream>

#include "station/sync/outbox.h"

int main(int argc, char** argv) {
  if (argc != 3) return 2;
  ves::sync::Outbox outbox(argv[1]);
  ves::v1::SessionRecord record;
  record.set_uuid("0f8fad5b-d9cb-469f-a165-70867728950e");
  record.set_trainee_id("t1");
  std::ofstream(argv[2], std::ios::app) << "commit begins\n";
  outbox.Commit(record);
  std::ofstream(argv[2], std::ios::app) << "commit returned\n";
  return 0;
}
