// OpenEXR output: named 32-bit float channels in one scan-line file (ZIP compression,
// lossless), written through OpenEXR's C++ API (Imf::OutputFile). The framebuffer's
// exact values when T is float (double is rounded to float, as PFM does).
//
// Needs OpenEXR 3 (Debian: libopenexr-dev): in CMake, find_package(OpenEXR CONFIG)
// and link OpenEXR::OpenEXR (twinray's own build does so through twinray::exr).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <string>
#include <utility>
#include <vector>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>

#include <twinray/core/error.hpp>
#include <twinray/core/image.hpp>
#include <twinray/io/atomic_file.hpp>

namespace twinray {
namespace io {

// One channel: `values` holds width * height floats, row 0 at the top of the image.
struct ExrChannel {
  std::string name;  // "R", "Z", "N.X" (OpenEXR's layer.channel naming)
  std::vector<float> values;
};

// Channel c (0, 1, 2) of an image, as floats.
template <class T>
std::vector<float> channel_of(const Image<T>& image, int c) {
  std::vector<float> out(static_cast<size_t>(image.width) * image.height);
  for (size_t i = 0; i < out.size(); ++i) out[i] = static_cast<float>(image.rgb[i * 3 + c]);
  return out;
}

namespace detail {

// An Imf::OStream into memory, so that the file's bytes go to disk through
// write_file_atomically() like every other output.
class ExrMemoryStream : public Imf::OStream {
 public:
  explicit ExrMemoryStream(const std::string& name) : Imf::OStream(name.c_str()) {}
  void write(const char c[], int n) override {
    if (pos_ + static_cast<size_t>(n) > bytes.size()) bytes.resize(pos_ + n);
    std::memcpy(bytes.data() + pos_, c, static_cast<size_t>(n));
    pos_ += static_cast<size_t>(n);
  }
  uint64_t tellp() override { return pos_; }
  void seekp(uint64_t pos) override { pos_ = static_cast<size_t>(pos); }
  std::vector<unsigned char> bytes;

 private:
  size_t pos_ = 0;
};

}  // namespace detail

// The EXR file's bytes. Throws Error(InvalidInput) when a channel has the wrong size or
// no name, or two channels share a name; Error(RuntimeFailure) when OpenEXR fails.
// `name` only appears in messages.
inline std::vector<unsigned char> encode_exr(int width, int height,
                                             const std::vector<ExrChannel>& channels,
                                             const std::string& name = "image.exr") {
  const size_t pixels = static_cast<size_t>(width) * static_cast<size_t>(height);
  if (width < 1 || height < 1 || channels.empty())
    throw Error(ErrorKind::InvalidInput,
                name + ": an EXR needs a size of 1x1 or more and a channel");
  try {
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    Imf::FrameBuffer frame;
    for (const ExrChannel& ch : channels) {
      if (ch.name.empty() || ch.values.size() != pixels ||
          header.channels().findChannel(ch.name) != nullptr)
        throw Error(ErrorKind::InvalidInput,
                    name + ": EXR channel \"" + ch.name +
                        "\" is unnamed, named twice, or not of width x height values");
      header.channels().insert(ch.name, Imf::Channel(Imf::FLOAT));
      // Imf::Slice takes a non-const base; OutputFile only reads through it.
      char* base = reinterpret_cast<char*>(const_cast<float*>(ch.values.data()));
      frame.insert(ch.name, Imf::Slice(Imf::FLOAT, base, sizeof(float),
                                       sizeof(float) * static_cast<size_t>(width)));
    }
    detail::ExrMemoryStream stream(name);
    {
      Imf::OutputFile file(stream, header);
      file.setFrameBuffer(frame);
      file.writePixels(height);
    }  // the destructor writes the line offset table
    return std::move(stream.bytes);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(ErrorKind::RuntimeFailure, name + ": OpenEXR: " + e.what());
  }
}

// Writes `path` atomically (io/atomic_file.hpp): complete, or the earlier file intact.
inline void write_exr(const std::string& path, int width, int height,
                      const std::vector<ExrChannel>& channels) {
  write_file_atomically(path, encode_exr(width, height, channels, path));
}

// The image as channels R, G, B.
template <class T>
void write_exr(const std::string& path, const Image<T>& image) {
  write_exr(
      path, image.width, image.height,
      {{"R", channel_of(image, 0)}, {"G", channel_of(image, 1)}, {"B", channel_of(image, 2)}});
}

// Reads every channel of a scan-line or tiled EXR as floats (OpenEXR converts HALF and
// UINT), in the file's channel order (sorted by name), row 0 at the top.
// Throws Error(InvalidInput) naming the path and OpenEXR's reason.
struct ExrImage {
  int width = 0, height = 0;
  std::vector<ExrChannel> channels;
  // The channel called `name`, or nullptr.
  const ExrChannel* find(const std::string& name) const {
    for (const ExrChannel& c : channels)
      if (c.name == name) return &c;
    return nullptr;
  }
};

inline ExrImage read_exr(const std::string& path) {
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i window = file.header().dataWindow();
    ExrImage out;
    out.width = window.max.x - window.min.x + 1;
    out.height = window.max.y - window.min.y + 1;
    const size_t pixels = static_cast<size_t>(out.width) * static_cast<size_t>(out.height);
    for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it)
      out.channels.push_back({it.name(), std::vector<float>(pixels)});
    Imf::FrameBuffer frame;
    for (ExrChannel& ch : out.channels) {
      // The slice's origin is pixel (0, 0) of the data window's coordinates.
      char* base = reinterpret_cast<char*>(ch.values.data()) -
                   (static_cast<std::ptrdiff_t>(window.min.x) +
                    static_cast<std::ptrdiff_t>(window.min.y) * out.width) *
                       static_cast<std::ptrdiff_t>(sizeof(float));
      frame.insert(ch.name, Imf::Slice(Imf::FLOAT, base, sizeof(float),
                                       sizeof(float) * static_cast<size_t>(out.width)));
    }
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    return out;
  } catch (const std::exception& e) {
    throw Error(ErrorKind::InvalidInput, path + ": cannot read as EXR: " + e.what());
  }
}

}  // namespace io
}  // namespace twinray
