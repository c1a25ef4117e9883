// Strict JSON reading, shared by the scene loader (io/scene_json.hpp) and the
// animation reader (io/animation_json.hpp), through nlohmann-json (Debian
// nlohmann-json3-dev).
//
// parse_json() parses text and refuses, as it reads, bad syntax, duplicate keys,
// nesting deeper than JsonLimits::max_nesting and more than JsonLimits::max_json_values
// values. JsonReader<T> then reads typed values out of the parsed document: objects
// with known keys only (with a "did you mean" for a near miss), strings, choices,
// integers and numbers in a range, numbers converted to T, 3-vectors. Every failure
// throws twinray::Error(InvalidInput) with the message `FILE: JSON.PATH: problem`, e.g.
//   scene.json: objects[3].radius: must be > 0, got -1
// docs/scene-format.md ("How values are read") describes the rules as a file's author
// sees them.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>

#include <twinray/core/error.hpp>

namespace twinray {
namespace io {

// Limits that hold while JSON text is parsed (SceneLimits extends them).
struct JsonLimits {
  int max_nesting = 64;                   // arrays and objects inside each other
  long long max_json_values = 1ll << 22;  // numbers, strings, ... in the whole file
};

namespace detail {

using Json = nlohmann::ordered_json;

// Levenshtein distance, for "did you mean" on unknown keys and names.
inline size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

// " (did you mean \"x\"?)" when one candidate is close, else "".
inline std::string suggestion(const std::string& got, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_distance = std::max<size_t>(2, got.size() / 3) + 1;
  for (const std::string& c : candidates) {
    size_t d = edit_distance(got, c);
    if (d < best_distance) best_distance = d, best = c;
  }
  return best.empty() ? "" : " (did you mean \"" + best + "\"?)";
}

inline std::string join(const std::vector<std::string>& items) {
  std::string s;
  for (size_t i = 0; i < items.size(); ++i) s += (i ? ", " : "") + items[i];
  return s;
}

// A JSON value as a short string for messages.
inline std::string show(const Json& v) {
  std::string s = v.dump();
  if (s.size() > 40) s = s.substr(0, 37) + "...";
  return s;
}

inline std::string kind_of(const Json& v) {
  if (v.is_number()) return "a number (" + show(v) + ")";
  if (v.is_string()) return "a string (" + show(v) + ")";
  if (v.is_boolean()) return std::string("a boolean (") + (v.get<bool>() ? "true" : "false") + ")";
  if (v.is_null()) return "null";
  if (v.is_array()) return "an array of " + std::to_string(v.size());
  return "an object";
}

// Tracks the JSON path while nlohmann parses, to refuse duplicate keys and deep
// nesting as they are read and to say where a syntax error is.
class PathTracker {
 public:
  PathTracker(const JsonLimits& limits, std::string file)
      : limits_(limits), file_(std::move(file)) {}

  bool on_event(Json::parse_event_t event, Json& parsed) {
    using E = Json::parse_event_t;
    switch (event) {
      case E::object_start:
      case E::array_start:
        begin_element();
        if (static_cast<int>(frames_.size()) >= limits_.max_nesting)
          fail(path() + (frames_.empty() ? "" : ": ") + "nested deeper than " +
               std::to_string(limits_.max_nesting) + " levels");
        frames_.push_back(Frame{event == E::array_start, -1, "", {}});
        break;
      case E::key: {
        Frame& f = frames_.back();
        f.key = parsed.get<std::string>();
        if (!f.keys.insert(f.key).second) fail(path() + ": duplicate key");
        break;
      }
      case E::value:
        begin_element();
        if (++values_ > limits_.max_json_values)
          fail(path() + ": more than " + std::to_string(limits_.max_json_values) +
               " JSON values in one file (put large meshes in an .obj file)");
        break;
      case E::object_end:
      case E::array_end:
        frames_.pop_back();
        break;
    }
    return true;
  }

  // The path of the value being read, `objects[3].radius`.
  std::string path() const { return path_of(false); }
  // The path of the value that was about to be read when the parser stopped: in an
  // array, the element after the last one read.
  std::string pending_path() const { return path_of(true); }

 private:
  std::string path_of(bool pending) const {
    std::string p;
    for (size_t i = 0; i < frames_.size(); ++i) {
      const Frame& f = frames_[i];
      if (f.array) {
        long long index = f.index + (pending && i + 1 == frames_.size() ? 1 : 0);
        if (index >= 0) p += "[" + std::to_string(index) + "]";
      } else if (!f.key.empty()) {
        p += (p.empty() ? "" : ".") + f.key;
      }
    }
    return p;
  }

  struct Frame {
    bool array;
    long long index;
    std::string key;
    std::set<std::string> keys;
  };
  void begin_element() {
    if (!frames_.empty() && frames_.back().array) ++frames_.back().index;
  }
  [[noreturn]] void fail(const std::string& problem) const {
    throw invalid_input(file_ + ": " + problem);
  }

  const JsonLimits& limits_;
  std::string file_;
  std::vector<Frame> frames_;
  long long values_ = 0;
};

// 1-based line and column of a byte offset.
inline std::string line_column(const std::string& text, size_t byte) {
  size_t line = 1, column = 1;
  for (size_t i = 0; i < byte && i < text.size(); ++i) {
    if (text[i] == '\n')
      ++line, column = 1;
    else
      ++column;
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(column);
}

// Parses JSON text strictly: syntax, duplicate keys, nesting, value count.
inline Json parse_json(const std::string& text, const std::string& file, const JsonLimits& limits) {
  PathTracker tracker(limits, file);
  try {
    return Json::parse(
        text,
        [&](int, Json::parse_event_t event, Json& parsed) {
          return tracker.on_event(event, parsed);
        },
        /*allow_exceptions=*/true, /*ignore_comments=*/false);
  } catch (const Json::parse_error& e) {
    // e.what(): "[json.exception.parse_error.101] parse error at line 3, column 5: syntax
    // error while parsing object - unexpected '}'; expected string literal"
    std::string what = e.what();
    size_t colon = what.find(": ", what.find("parse error"));
    std::string detail = colon == std::string::npos ? what : what.substr(colon + 2);
    std::string where = tracker.pending_path();
    throw invalid_input(file + ": invalid JSON at " +
                        line_column(text, e.byte > 0 ? e.byte - 1 : 0) +
                        (where.empty() ? "" : " (near " + where + ")") + ": " + detail);
  } catch (const Json::out_of_range& e) {
    // A number too large for a double (1e999) or an integer type.
    std::string what = e.what();
    size_t quote = what.find('\'');
    std::string number = quote == std::string::npos ? "" : what.substr(quote);
    std::string where = tracker.pending_path();
    throw invalid_input(file + ": " + (where.empty() ? "(top level)" : where) +
                        ": number out of range (not a finite double)" +
                        (number.empty() ? "" : ": " + number));
  }
}

template <class T>
const char* precision_name() {
  return std::is_same<T, float>::value ? "float" : "double";
}

// Reads typed values out of a parsed document; every failure names the file and the
// JSON path. T is the precision numbers are converted to (scalar(), vector3()).
template <class T>
class JsonReader {
 public:
  using vec3 = glm::vec<3, T>;

  explicit JsonReader(std::string file) : file_(std::move(file)) {}

  // The file as named in messages.
  const std::string& file() const { return file_; }

  [[noreturn]] void fail(const std::string& path, const std::string& problem) const {
    throw invalid_input(file_ + ": " + (path.empty() ? "(top level)" : path) + ": " + problem);
  }

  static std::string key_path(const std::string& parent, const std::string& key) {
    return parent.empty() ? key : parent + "." + key;
  }
  static std::string index_path(const std::string& parent, size_t i) {
    return parent + "[" + std::to_string(i) + "]";
  }

  void require_object(const Json& v, const std::string& path) const {
    if (!v.is_object()) fail(path, "must be an object, got " + kind_of(v));
  }
  void require_array(const Json& v, const std::string& path) const {
    if (!v.is_array()) fail(path, "must be an array, got " + kind_of(v));
  }

  // Refuses keys outside `allowed`, with a suggestion for a near miss.
  void check_keys(const Json& object, const std::string& path,
                  const std::vector<std::string>& allowed) const {
    for (auto it = object.begin(); it != object.end(); ++it)
      if (std::find(allowed.begin(), allowed.end(), it.key()) == allowed.end())
        fail(key_path(path, it.key()),
             "unknown key" + suggestion(it.key(), allowed) + "; allowed here: " + join(allowed));
  }

  const Json& require(const Json& object, const std::string& path, const std::string& key) const {
    auto it = object.find(key);
    if (it == object.end()) fail(key_path(path, key), "missing (required)");
    return *it;
  }
  const Json* optional(const Json& object, const std::string& key) const {
    auto it = object.find(key);
    return it == object.end() ? nullptr : &*it;
  }

  // A finite JSON number, as double.
  double number(const Json& v, const std::string& path) const {
    if (!v.is_number()) fail(path, "must be a number, got " + kind_of(v));
    double d = v.get<double>();
    if (!std::isfinite(d)) fail(path, "number out of range (not a finite double): " + show(v));
    return d;
  }

  // A number converted to T, refused if it overflows T or leaves [lo, hi].
  T scalar(const Json& v, const std::string& path, double lo = -INFINITY, double hi = INFINITY,
           bool lo_open = false) const {
    double d = number(v, path);
    T t = static_cast<T>(d);
    if (!std::isfinite(t))
      fail(path, show(v) + " overflows " + precision_name<T>() + " (largest " +
                     format_number(std::numeric_limits<T>::max()) + ")");
    bool ok = (lo_open ? t > T(lo) : t >= T(lo)) && t <= T(hi);
    if (!ok) {
      std::string want = std::isinf(hi)
                             ? std::string(lo_open ? "> " : ">= ") + format_number(lo)
                             : "in [" + format_number(lo) + ", " + format_number(hi) + "]";
      if (lo_open && t == T(0) && d != 0.0)
        fail(path,
             "must be " + want + ", got " + show(v) + ", which is 0 in " + precision_name<T>());
      fail(path, "must be " + want + ", got " + show(v));
    }
    return t;
  }

  long long integer(const Json& v, const std::string& path, long long lo, long long hi) const {
    std::string want = "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    if (!v.is_number()) fail(path, "must be " + want + ", got " + kind_of(v));
    if (!v.is_number_integer()) fail(path, "must be " + want + ", got " + show(v));
    bool ok;
    long long i = 0;
    if (v.is_number_unsigned()) {
      unsigned long long u = v.get<unsigned long long>();
      ok = u <= static_cast<unsigned long long>(hi);
      i = ok ? static_cast<long long>(u) : 0;
      ok = ok && i >= lo;
    } else {
      i = v.get<long long>();
      ok = i >= lo && i <= hi;
    }
    if (!ok) fail(path, "must be " + want + ", got " + show(v));
    return i;
  }

  bool boolean(const Json& v, const std::string& path) const {
    if (!v.is_boolean()) fail(path, "must be true or false, got " + kind_of(v));
    return v.get<bool>();
  }

  std::string string(const Json& v, const std::string& path) const {
    if (!v.is_string()) fail(path, "must be a string, got " + kind_of(v));
    return v.get<std::string>();
  }

  // One of `choices`.
  std::string choice(const Json& v, const std::string& path,
                     const std::vector<std::string>& choices) const {
    std::string s = string(v, path);
    if (std::find(choices.begin(), choices.end(), s) == choices.end()) {
      std::vector<std::string> quoted;
      for (const std::string& c : choices) quoted.push_back("\"" + c + "\"");
      fail(path, "must be " + join(quoted) + ", got \"" + s + "\"" + suggestion(s, choices));
    }
    return s;
  }

  // An array of exactly three numbers, each in [lo, hi].
  vec3 vector3(const Json& v, const std::string& path, double lo = -INFINITY,
               double hi = INFINITY) const {
    if (!v.is_array() || v.size() != 3)
      fail(path, "must be an array of 3 numbers, got " + kind_of(v));
    vec3 out;
    for (size_t k = 0; k < 3; ++k) out[k] = scalar(v[k], index_path(path, k), lo, hi);
    return out;
  }

  static std::string format_number(double v) {
    std::ostringstream os;
    os.precision(9);
    os << v;
    return os.str();
  }

 private:
  std::string file_;
};

}  // namespace detail
}  // namespace io
}  // namespace twinray
