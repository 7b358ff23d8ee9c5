/* LD_PRELOAD spy for the outbox's durability test: every fsync and fdatasync
   appends the path of its file descriptor to $VES_FSYNC_SPY_LOG, then calls
   the real one. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static void Note(const char* call, int fd) {
  const char* log = getenv("VES_FSYNC_SPY_LOG");
  if (log == NULL) return;
  char link[64];
  char path[4096];
  snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  const ssize_t n = readlink(link, path, sizeof path - 1);
  path[n > 0 ? n : 0] = '\0';
  const int out = open(log, O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (out < 0) return;
  char line[4200];
  const int len = snprintf(line, sizeof line, "%s %s\n", call, path);
  if (len > 0) (void)!write(out, line, (size_t)len);
  close(out);
}

int fsync(int fd) {
  static int (*real)(int) = NULL;
  if (real == NULL) real = (int (*)(int))dlsym(RTLD_NEXT, "fsync");
  Note("fsync", fd);
  return real(fd);
}

int fdatasync(int fd) {
  static int (*real)(int) = NULL;
  if (real == NULL) real = (int (*)(int))dlsym(RTLD_NEXT, "fdatasync");
  Note("fdatasync", fd);
  return real(fd);
}
