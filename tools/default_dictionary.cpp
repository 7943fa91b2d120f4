#include "default_dictionary.hpp"

#include <iostream>

#include "progress.hpp"

namespace potmap::cli {

Dictionary default_dictionary(std::string* where, int dim) {
  experiment::DefaultDictionaryNotes notes;
  notes.note = [](const std::string& line) { std::cerr << "potmap: " << line << "\n"; };
  notes.start_progress = [dim] {
    return terminal_progress(dim == 3 ? "3D default dictionary" : "default dictionary");
  };
  return experiment::default_dictionary(dim, where, notes);
}

}  // namespace potmap::cli
