// OBJ loading: twinray's parser (io/obj_mesh.hpp) against tinyobjloader and, when
// their sources are given to CMake, fast_obj and rapidobj. Prints, per file and
// loader, the best wall time of --rounds loads and the peak memory the load added, and
// for twinray that peak over the bytes of the mesh it keeps.
//
//   obj_load_bench [--triangles N] [--rounds R] [--folder DIR] [--keep] [FILE.obj ...]
//
// Without files it writes two of about N triangles (default 1e6) into DIR (default
// the system's temporary folder): a grid with positions only (`f a b c`), and the
// same grid with texture coordinates and normals (`f a/a/a b/b/b c/c/c`), removed at
// the end unless --keep is given. Each load runs in a child process of its own
// (fork), so that one loader's freed memory cannot lower the next one's peak; the
// peak is the child's resident high-water mark (/proc/self/status VmHWM, reset
// through /proc/self/clear_refs) less its resident size before the load. The files are read once
// first, so every loader finds them in the page cache. The comparators read floats and check less:
// tinyobjloader and fast_obj take `1x` as 1 and drop faces with bad indices; none refuses NaN.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <twinray/core/parallel.hpp>
#include <twinray/io/obj_mesh.hpp>

#ifdef TWINRAY_BENCH_WITH_TINYOBJLOADER
#include <tiny_obj_loader.h>
#endif
#ifdef TWINRAY_BENCH_WITH_FAST_OBJ
#define FAST_OBJ_IMPLEMENTATION
#include <fast_obj.h>
#endif
#ifdef TWINRAY_BENCH_WITH_RAPIDOBJ
#include <rapidobj/rapidobj.hpp>
#endif

namespace {

// A (w + 1) x (h + 1) vertex grid of 2 w h triangles, slightly bumped so that the
// numbers have all their digits.
void write_grid(const std::string& path, int w, int h, bool attributes) {
  std::ofstream out(path, std::ios::binary);
  std::vector<char> buffer(1 << 20);
  out.rdbuf()->pubsetbuf(buffer.data(), static_cast<std::streamsize>(buffer.size()));
  char line[160];
  for (int j = 0; j <= h; ++j)
    for (int i = 0; i <= w; ++i) {
      double x = double(i) / w, z = double(j) / h, y = 0.05 * std::sin(9 * x) * std::cos(7 * z);
      out.write(line, std::snprintf(line, sizeof line, "v %.6f %.6f %.6f\n", x, y, z));
      if (attributes) {
        out.write(line, std::snprintf(line, sizeof line, "vt %.6f %.6f\n", x, z));
        out.write(line, std::snprintf(line, sizeof line, "vn %.6f %.6f %.6f\n",
                                      -0.45 * std::cos(9 * x) * std::cos(7 * z), 1.0,
                                      0.35 * std::sin(9 * x) * std::sin(7 * z)));
      }
    }
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) {
      long a = 1 + j * (w + 1) + i, b = a + 1, c = a + w + 1, d = c + 1;
      if (attributes) {
        out.write(line, std::snprintf(line, sizeof line, "f %ld/%ld/%ld %ld/%ld/%ld %ld/%ld/%ld\n",
                                      a, a, a, b, b, b, d, d, d));
        out.write(line, std::snprintf(line, sizeof line, "f %ld/%ld/%ld %ld/%ld/%ld %ld/%ld/%ld\n",
                                      a, a, a, d, d, d, c, c, c));
      } else {
        out.write(line, std::snprintf(line, sizeof line, "f %ld %ld %ld\nf %ld %ld %ld\n", a, b, d,
                                      a, d, c));
      }
    }
}

long status_kib(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string word;
  while (in >> word)
    if (word == key) {
      long kib = 0;
      in >> kib;
      return kib;
    }
  return -1;
}

struct Measure {
  double seconds = 0;
  double peak_mib = 0;  // resident memory the load added at its peak
  double kept_mib = 0;  // what the loader's result holds
  long long triangles = 0;
  bool ok = false;
};

// Runs load() in a child process; it returns the bytes its result keeps and sets the
// triangle count.
Measure measure(const std::function<long long(long long&)>& load) {
  int fd[2];
  if (pipe(fd) != 0) return {};
  pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    Measure m;
    { std::ofstream("/proc/self/clear_refs") << "5"; }  // reset VmHWM to VmRSS
    long before = status_kib("VmRSS:");
    auto t0 = std::chrono::steady_clock::now();
    try {
      m.kept_mib = double(load(m.triangles)) / (1 << 20);
      m.ok = true;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "load failed: %s\n", e.what());
    }
    m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    m.peak_mib = double(status_kib("VmHWM:") - before) / 1024;
    if (write(fd[1], &m, sizeof m) != sizeof m) _exit(1);
    _exit(0);
  }
  close(fd[1]);
  Measure m;
  if (read(fd[0], &m, sizeof m) != sizeof m) m.ok = false;
  close(fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  return m;
}

template <class V>
long long bytes(const std::vector<V>& v) {
  return static_cast<long long>(v.size() * sizeof(V));
}

long long twinray_load(const std::string& path, int threads, long long& triangles) {
  twinray::set_thread_count(threads);
  twinray::Mesh<float> mesh = twinray::io::load_obj_mesh<float>(path);
  triangles = static_cast<long long>(mesh.triangles.size());
  return bytes(mesh.vertices) + bytes(mesh.triangles) + bytes(mesh.normals) +
         bytes(mesh.normal_triangles) + bytes(mesh.uvs) + bytes(mesh.uv_triangles) +
         bytes(mesh.triangle_materials);
}

}  // namespace

int main(int argc, char** argv) {
  long long triangles = 1000000;
  int rounds = 3;
  std::string folder = std::filesystem::temp_directory_path().string();
  std::vector<std::string> files;
  bool keep = false;  // leave the written files in the folder (their names go to stderr)
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--triangles" && i + 1 < argc)
      triangles = static_cast<long long>(std::atof(argv[++i]));  // 4e6 or 4000000
    else if (a == "--rounds" && i + 1 < argc)
      rounds = std::max(1, std::atoi(argv[++i]));
    else if (a == "--folder" && i + 1 < argc)
      folder = argv[++i];
    else if (a == "--keep")
      keep = true;
    else if (!a.empty() && a[0] != '-')
      files.push_back(a);
    else {
      std::cerr << "usage: obj_load_bench [--triangles N] [--rounds R] [--folder DIR] [--keep] "
                   "[FILE.obj ...]\n";
      return 2;
    }
  }
  std::vector<std::string> made;
  if (files.empty()) {
    int h = std::max(1, static_cast<int>(std::sqrt(double(triangles) / 8)));
    int w = std::max(1, static_cast<int>(triangles / (2ll * h)));
    for (bool attributes : {false, true}) {
      std::string path = folder + "/twinray_obj_bench_" + std::to_string(getpid()) +
                         (attributes ? "_vt_vn.obj" : "_v.obj");
      write_grid(path, w, h, attributes);
      files.push_back(path);
      made.push_back(path);
    }
  }

  std::printf("file,loader,threads,triangles,MB,best_s,peak_MiB,kept_MiB,peak_over_kept\n");
  for (const std::string& path : files) {
    {  // into the page cache
      std::ifstream in(path, std::ios::binary);
      std::vector<char> block(1 << 20);
      while (in.read(block.data(), static_cast<std::streamsize>(block.size())) || in.gcount()) {
      }
    }
    const double mb = double(std::filesystem::file_size(path)) / 1e6;
    auto report = [&](const char* loader, int threads,
                      const std::function<long long(long long&)>& load) {
      Measure best;
      for (int r = 0; r < rounds; ++r) {
        Measure m = measure(load);
        if (!m.ok) {
          std::printf("%s,%s,%d,failed\n", path.c_str(), loader, threads);
          return;
        }
        if (r == 0 || m.seconds < best.seconds) best.seconds = m.seconds;
        best.peak_mib = std::max(best.peak_mib, m.peak_mib);
        best.kept_mib = m.kept_mib;
        best.triangles = m.triangles;
      }
      std::printf("%s,%s,%d,%lld,%.1f,%.3f,%.1f,%.1f,%.2f\n",
                  std::filesystem::path(path).filename().c_str(), loader, threads, best.triangles,
                  mb, best.seconds, best.peak_mib, best.kept_mib,
                  best.kept_mib > 0 ? best.peak_mib / best.kept_mib : 0.0);
      std::fflush(stdout);
    };
    for (int threads : {1, 2})
      report("twinray", threads, [&](long long& t) { return twinray_load(path, threads, t); });
#ifdef TWINRAY_BENCH_WITH_TINYOBJLOADER
    report("tinyobjloader", 1, [&](long long& t) {
      tinyobj::attrib_t attrib;
      std::vector<tinyobj::shape_t> shapes;
      std::vector<tinyobj::material_t> materials;
      std::string warn, err;
      if (!tinyobj::LoadObj(&attrib, &shapes, &materials, &warn, &err, path.c_str(), nullptr, true))
        throw std::runtime_error(err);
      t = 0;
      long long kept = bytes(attrib.vertices) + bytes(attrib.normals) + bytes(attrib.texcoords);
      for (const auto& s : shapes) {
        t += static_cast<long long>(s.mesh.num_face_vertices.size());
        kept +=
            bytes(s.mesh.indices) + bytes(s.mesh.num_face_vertices) + bytes(s.mesh.material_ids);
      }
      return kept;
    });
#endif
#ifdef TWINRAY_BENCH_WITH_FAST_OBJ
    report("fast_obj", 1, [&](long long& t) {
      fastObjMesh* m = fast_obj_read(path.c_str());
      if (!m) throw std::runtime_error("fast_obj_read failed");
      t = m->face_count;
      long long kept = 4ll * (3 * m->position_count + 2 * m->texcoord_count + 3 * m->normal_count) +
                       12ll * m->index_count + 8ll * m->face_count;
      fast_obj_destroy(m);
      return kept;
    });
#endif
#ifdef TWINRAY_BENCH_WITH_RAPIDOBJ
    // rapidobj parses on every hardware thread.
    report("rapidobj", static_cast<int>(std::thread::hardware_concurrency()), [&](long long& t) {
      rapidobj::Result r = rapidobj::ParseFile(path);
      if (r.error) throw std::runtime_error(r.error.code.message());
      t = 0;
      long long kept =
          4ll * static_cast<long long>(r.attributes.positions.size() +
                                       r.attributes.texcoords.size() + r.attributes.normals.size());
      for (const auto& s : r.shapes) {
        t += static_cast<long long>(s.mesh.num_face_vertices.size());
        kept += 12ll * static_cast<long long>(s.mesh.indices.size()) +
                5ll * static_cast<long long>(s.mesh.num_face_vertices.size());
      }
      return kept;
    });
#endif
  }
  for (const std::string& path : made) {
    if (keep)
      std::cerr << "kept " << path << "\n";
    else
      std::filesystem::remove(path);
  }
  return 0;
}
