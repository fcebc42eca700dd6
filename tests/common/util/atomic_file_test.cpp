// AtomicFile (common/src/util/atomic_file.cpp): commit replaces the target, an
// abandoned replacement leaves it alone, stale temporaries of dead processes
// go, sync errors are reported; EarlyWriteback's steps.
#include "mocap/common/util/atomic_file.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <string>

#include "mocap/common/util/error.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

std::string read(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(AtomicFile, CommitReplacesTheTarget) {
  const fs::path dir = test::temp_dir("atomic-commit");
  const fs::path target = dir / "index.h5";
  write(target, "old");
  {
    AtomicFile file(target);
    EXPECT_EQ(file.target(), target);
    EXPECT_EQ(file.temporary_path(), dir / (".index.h5.tmp-" + std::to_string(::getpid())));
    EXPECT_FALSE(fs::exists(file.temporary_path())) << "the caller creates it";
    write(file.temporary_path(), "new");
    file.commit();
    EXPECT_FALSE(fs::exists(file.temporary_path()));
  }
  EXPECT_EQ(read(target), "new");
}

TEST(AtomicFile, AbandonedReplacementLeavesTheTargetAlone) {
  const fs::path dir = test::temp_dir("atomic-abandon");
  const fs::path target = dir / "index.h5";
  write(target, "old");
  fs::path temporary;
  {
    AtomicFile file(target);
    temporary = file.temporary_path();
    write(temporary, "half written");
  }
  EXPECT_FALSE(fs::exists(temporary));
  EXPECT_EQ(read(target), "old");
}

TEST(AtomicFile, CreatesTheMissingFolder) {
  const fs::path target = test::temp_dir("atomic-folder") / "a" / "b" / "index.h5";
  AtomicFile file(target);
  EXPECT_TRUE(fs::is_directory(target.parent_path()));
  write(file.temporary_path(), "x");
  file.commit();
  EXPECT_EQ(read(target), "x");
}

TEST(AtomicFile, RemovesStaleTemporariesOfDeadProcessesOnly) {
  const fs::path dir = test::temp_dir("atomic-stale");
  const fs::path target = dir / "index.h5";
  // Above any pid_max (2^22): no such process.
  const fs::path dead = dir / ".index.h5.tmp-999999999";
  const fs::path own = dir / (".index.h5.tmp-" + std::to_string(::getpid()));
  const fs::path running = dir / (".index.h5.tmp-" + std::to_string(::getppid()));
  const fs::path not_a_pid = dir / ".index.h5.tmp-abc";
  const fs::path other_target = dir / ".other.h5.tmp-999999999";
  for (const auto& p : {dead, own, running, not_a_pid, other_target}) write(p, "x");
  remove_stale_temporaries(target);
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_FALSE(fs::exists(own));
  EXPECT_TRUE(fs::exists(running));
  EXPECT_TRUE(fs::exists(not_a_pid));
  EXPECT_TRUE(fs::exists(other_target));
  // Constructing a replacement does the same.
  write(dead, "x");
  AtomicFile file(target);
  EXPECT_FALSE(fs::exists(dead));
}

TEST(AtomicFile, SyncErrorsNameThePath) {
  const fs::path dir = test::temp_dir("atomic-sync");
  write(dir / "f", "x");
  EXPECT_NO_THROW(sync_to_disk(dir / "f", false));
  EXPECT_NO_THROW(sync_to_disk(dir, true));
  try {
    sync_to_disk(dir / "missing", false);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), (dir / "missing").string());
  }
  // Committing without having written the temporary file fails; the target is untouched.
  write(dir / "index.h5", "old");
  AtomicFile file(dir / "index.h5");
  EXPECT_THROW(file.commit(), InputError);
  EXPECT_EQ(read(dir / "index.h5"), "old");
}

// Early writeback: nothing for a file it cannot open; on a growing file it
// starts writing once every `every_bytes` more bytes are in it, and the
// file's content is what was written.
TEST(EarlyWriteback, StartsOnceEveryStepAndOnlyOnFilesItCanOpen) {
  const fs::path dir = test::temp_dir("early-writeback");
  EarlyWriteback none(dir / "missing.h5", 10);
  none.kick();
  EXPECT_EQ(none.started_bytes(), 0u);
  const fs::path path = dir / "growing.h5";
  std::ofstream out(path, std::ios::binary);
  EarlyWriteback writeback(path, 1000);
  std::string all;
  for (int step = 0; step < 5; ++step) {
    const std::string chunk(600, static_cast<char>('a' + step));
    out << chunk << std::flush;
    all += chunk;
    writeback.kick();
    // 600, 1200 (>= 1000: started), 1800, 2400 (>= 2200: started), 3000.
    const std::uint64_t expected = step < 1 ? 0 : step < 3 ? 1200 : 2400;
    EXPECT_EQ(writeback.started_bytes(), expected) << step;
  }
  out.close();
  EXPECT_EQ(read(path), all);
}

TEST(OutputLock, ASecondLockOnOneTargetFailsUntilTheFirstIsGone) {
  const fs::path dir = test::temp_dir("output-lock");
  EXPECT_THROW(OutputLock(dir / "missing-folder" / "i.h5"), InputError);
  {
    const OutputLock first(dir / "i.h5");
    EXPECT_EQ(first.lock_path(), dir / ".i.h5.lock");
    try {
      const OutputLock second(dir / "i.h5");
      FAIL() << "two locks on one target";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("another process"), std::string::npos) << e.what();
    }
    EXPECT_NO_THROW(OutputLock(dir / "other.h5"));  // another target
  }
  EXPECT_NO_THROW(OutputLock(dir / "i.h5"));  // released
}

}  // namespace
}  // namespace mocap
