#include "potmap/experiments/default_dictionary.hpp"

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iterator>
#include <sstream>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/experiments/experiment_frames.hpp"
#include "potmap/pot/dictionary_io.hpp"

namespace potmap::experiment {

namespace {

constexpr const char* kTowns[] = {"town1", "town2", "town3"};
constexpr double kSpacing = 2.0;    // metres between scans, as the experiments' simulated drives
constexpr double kRangeCut = 20.0;  // the towns' sensor range, the radius atoms are cut with

// An advisory lock on PATH.lock for as long as it lives; nothing when the file cannot be made.
class BuildLock {
 public:
  explicit BuildLock(const std::string& path) {
    if (path.empty()) return;
    fd_ = ::open((path + ".lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ >= 0 && ::flock(fd_, LOCK_EX) != 0) {
      ::close(fd_);
      fd_ = -1;
    }
  }
  ~BuildLock() {
    if (fd_ >= 0) ::close(fd_);  // closing releases the lock
  }
  BuildLock(const BuildLock&) = delete;
  BuildLock& operator=(const BuildLock&) = delete;

 private:
  int fd_ = -1;
};

// Atoms of the three towns, each driven as `drive` says, cut at the towns' range. One town at a
// time, so that progress can be shown between them; build_atoms appends the atoms of its places
// in order, so the dictionary is the one a single call over all three towns gives, byte for
// byte.
Dictionary atoms_of_towns(const PotSetup& setup, const SimOptions& drive,
                          const std::function<void(double)>& progress) {
  Dictionary dict;
  const std::size_t towns = std::size(kTowns);
  for (std::size_t t = 0; t < towns; ++t) {
    Simulation sim = simulate(Town::builtin(kTowns[t], 0), drive);
    std::vector<std::vector<Scan>> place(1);
    for (Scan& s : sim.scans) place[0].push_back(limit_range(s, kRangeCut));
    Dictionary part = build_atoms(nullptr, place, setup, 0);
    if (dict.empty()) {
      dict = std::move(part);
    } else {
      for (Atom& a : part.atoms) dict.atoms.push_back(std::move(a));
    }
    if (progress) progress(double(t + 1) / towns);
  }
  return dict;
}

}  // namespace

Dictionary build_default_dictionary(std::size_t scans,
                                    const std::function<void(double)>& progress) {
  PotSetup setup;
  setup.dictionary.source = default_dictionary_recipe();
  SimOptions o;
  o.scans = scans;
  o.spacing = kSpacing;
  o.seed = 0;
  return atoms_of_towns(setup, o, progress);
}

Dictionary build_default_dictionary_3d(std::size_t scans,
                                       const std::function<void(double)>& progress) {
  PotSetup setup = frame_setup_3d().pot;
  setup.dictionary.source = default_dictionary_recipe(3);
  return atoms_of_towns(setup, sim_options_3d(scans, 0), progress);
}

Dictionary default_dictionary(int dim, std::string* where, const DefaultDictionaryNotes& notes) {
  if (dim != 2 && dim != 3)
    throw ArgumentError("default dictionary: dim must be 2 or 3, got " + std::to_string(dim));
  auto note = [&](const std::string& s) {
    if (notes.note) notes.note(s);
  };
  const std::string path = default_dictionary_path(dim);
  if (where) *where = path;
  std::error_code ec;
  if (!path.empty())
    std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
  // Two runs started together build it once: the second waits here, then reads the cache.
  const BuildLock lock(path);
  if (!path.empty() && std::filesystem::exists(path, ec)) {
    try {
      return read_dictionary(path);
    } catch (const InputError& e) {
      note(std::string("the cached default dictionary is unreadable, building it again (") +
           e.what() + ")");
    }
  }
  note("building the default dictionary (" + default_dictionary_recipe(dim) +
       "); once, then cached in " + (path.empty() ? "(no cache folder)" : path));
  const auto t0 = std::chrono::steady_clock::now();
  const std::function<void(double)> progress =
      notes.start_progress ? notes.start_progress() : std::function<void(double)>();
  Dictionary dict = dim == 3 ? build_default_dictionary_3d(20, progress)
                             : build_default_dictionary(200, progress);
  if (!path.empty()) {
    try {
      write_dictionary(dict, path);
    } catch (const Error& e) {
      note(std::string("could not cache the default dictionary: ") + e.what());
      if (where) where->clear();
    }
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::ostringstream line;
  line << "default dictionary: " << dict.size() << " atoms in " << s << " s";
  note(line.str());
  return dict;
}

}  // namespace potmap::experiment
