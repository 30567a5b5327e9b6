#include "io/image_load.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>

#include <csetjmp>
#include <cstdio>

#include <jpeglib.h>
#include <stb/stb_image.h>
#include <tinyexr.h>

#include "core/texture.h"
#include "io/host_memory.h"

namespace pn {

namespace {

std::string lower_extension(const std::string& path) {
  auto slash = path.find_last_of("/\\");
  auto dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

bool size_ok(int w, int h, std::string* error) {
  if (w <= 0 || h <= 0) {
    *error = "image has no pixels";
    return false;
  }
  if (size_t(w) * size_t(h) > kMaxImageTexels) {
    *error = "image too large (" + std::to_string(w) + "x" + std::to_string(h) + ")";
    return false;
  }
  return true;
}

// Radiance is finite and never negative: channels that are not become 0.
// Returns how many texels had one.
size_t repair_float_texels(std::vector<uint8_t>& texels) {
  size_t repaired = 0;
  const size_t n = texels.size() / 16;
  for (size_t i = 0; i < n; ++i) {
    float c[4];
    std::memcpy(c, &texels[16 * i], sizeof c);
    bool bad = false;
    for (float& v : c)
      if (!(v >= 0.f) || !std::isfinite(v)) {  // NaN fails v >= 0
        v = 0.f;
        bad = true;
      }
    if (bad) {
      std::memcpy(&texels[16 * i], c, sizeof c);
      ++repaired;
    }
  }
  return repaired;
}

// Whether stb_image's Radiance HDR decoder ends on these bytes. Its run-length
// decoder (Debian's stb of 2022-09) loops forever on a count of 0, which any
// truncated file reaches (it reads 0 past the end): found by fuzz_image, the
// file is tests/fuzz/regressions/image/hdr-rle-zero-count-never-ends.hdr. This
// walks the scanlines as stbi__hdr_load does, without decoding them; anything
// else stb rejects by itself.
bool hdr_decoder_ends(const uint8_t* data, size_t size) {
  size_t pos = 0;
  auto at_eof = [&]() { return pos >= size; };
  auto get8 = [&]() -> unsigned { return pos < size ? data[pos++] : 0u; };
  // stbi__hdr_gettoken, to the letter: a line of at most 1023 characters (the
  // rest of a longer one skipped), the last byte of the file never part of it,
  // and read as a C string (up to the first NUL: a line of NULs ends the header).
  auto token = [&]() {
    char buf[1024];
    int len = 0;
    char c = char(get8());
    while (!at_eof() && c != '\n') {
      buf[len++] = c;
      if (len == 1023) {
        while (!at_eof() && get8() != '\n') {
        }
        break;
      }
      c = char(get8());
    }
    buf[len] = 0;
    return std::string(buf);
  };
  const std::string magic = token();
  if (magic != "#?RADIANCE" && magic != "#?RGBE") return true;
  bool valid = false;
  for (std::string t; !(t = token()).empty();) valid = valid || t == "FORMAT=32-bit_rle_rgbe";
  if (!valid) return true;
  const std::string res = token();
  if (res.compare(0, 3, "-Y ") != 0) return true;
  char* end = nullptr;
  const long height = int(std::strtol(res.c_str() + 3, &end, 10));  // stb keeps an int
  while (*end == ' ') ++end;
  if (std::strncmp(end, "+X ", 3) != 0) return true;
  const long width = int(std::strtol(end + 3, nullptr, 10));
  if (width < 8 || width >= 32768 || height <= 0) return true;  // flat scanlines: no runs
  for (long y = 0; y < height; ++y) {
    const unsigned c1 = get8(), c2 = get8(), hi = get8();
    if (c1 != 2 || c2 != 2 || (hi & 0x80)) return true;  // not run-length encoded: read flat
    if (long((hi << 8) | get8()) != width) return true;  // stb: "invalid decoded scanline length"
    for (int k = 0; k < 4; ++k)
      for (long i = 0; i < width;) {
        unsigned count = get8();
        if (count > 128) {
          count -= 128;
          get8();
        } else if (count == 0) {
          return false;  // stb would add 0 pixels and read the same count again, forever
        } else {
          pos += count;
        }
        if (long(count) > width - i) return true;  // stb: "bad RLE data in HDR"
        i += long(count);
      }
  }
  return true;
}

bool is_exr(const uint8_t* d, size_t n) { return n >= 4 && d[0] == 0x76 && d[1] == 0x2f && d[2] == 0x31 && d[3] == 0x01; }

// Whether decoding a w x h image fits in memory: ours, the decoder's own copy
// and (EXR) its per-channel planes. Checked from the header, before decoding.
bool memory_ok(int w, int h, bool is_float, std::string* error) {
  const uint64_t texels = uint64_t(w) * uint64_t(h);
  try {
    check_memory("decoding a " + std::to_string(w) + "x" + std::to_string(h) + " image",
                 {{"texels", texels * (is_float ? 16 : 4)}, {"the decoder's buffers", texels * (is_float ? 32 : 4)}});
  } catch (const std::exception& e) {
    *error = e.what();
    return false;
  }
  return true;
}

// JPEG: libjpeg-turbo, not stb_image. Debian's libstb is built with its
// assertions on, and stb's Huffman decoder asserts (aborts the process) on a
// malformed code table, which CI's fuzz_image found; libjpeg reports every
// error through its error manager, which returns here by longjmp.

// What stb_image takes for a JPEG (its first marker SOI, after any 0xFF fill
// bytes) goes to libjpeg, which refuses the fill bytes in one line.
bool is_jpeg(const uint8_t* d, size_t n) {
  size_t i = 0;
  if (n == 0 || d[0] != 0xFF) return false;
  while (i < n && d[i] == 0xFF) ++i;
  return i < n && d[i] == 0xD8;
}

// Formats stb_image would also decode but penumbra does not take as textures
// (docs/scene-format.md): GIF, PSD, Softimage PIC, PNM. Refused before stb, so
// that its decoders of them, with its assertions, never see a file.
const char* unsupported_format(const uint8_t* d, size_t n) {
  auto starts = [&](const char* magic, size_t k) { return n >= k && std::memcmp(d, magic, k) == 0; };
  if (starts("GIF8", 4)) return "GIF";
  if (starts("8BPS", 4)) return "PSD";
  if (starts("\x53\x80\xF6\x34", 4)) return "Softimage PIC";
  if (n >= 2 && d[0] == 'P' && (d[1] == '5' || d[1] == '6')) return "PNM";
  return nullptr;
}

struct JpegErrors {
  jpeg_error_mgr mgr;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

void jpeg_fail(j_common_ptr cinfo) {
  auto* e = reinterpret_cast<JpegErrors*>(cinfo->err);
  cinfo->err->format_message(cinfo, e->message);
  std::longjmp(e->jump, 1);
}

// A corrupt stream is a warning to libjpeg, which then fills in grey and goes
// on: here it is an error, so that a damaged texture is never silently drawn.
void jpeg_warning(j_common_ptr cinfo, int level) {
  if (level < 0) jpeg_fail(cinfo);
}

// Progressive JPEGs may hold any number of scans, each a pass over the whole
// image: a few hundred bytes can keep the decoder busy for minutes (the same
// limit as libjpeg-turbo's TJFLAG_LIMITSCANS).
constexpr int kMaxJpegScans = 500;
void jpeg_progress(j_common_ptr cinfo) {
  auto* d = reinterpret_cast<j_decompress_ptr>(cinfo);
  if (d->is_decompressor && d->input_scan_number > kMaxJpegScans) {
    auto* e = reinterpret_cast<JpegErrors*>(cinfo->err);
    std::snprintf(e->message, sizeof e->message, "more than %d progressive scans", kMaxJpegScans);
    std::longjmp(e->jump, 1);
  }
}

// RGBA, 8 bits a channel, into *rgba (null: the header alone, for *w and *h);
// false with *error otherwise. Only plain data lives between setjmp and the
// longjmp (the vector is the caller's).
bool decode_jpeg(const uint8_t* data, size_t size, bool want_float, int* w, int* h, std::vector<uint8_t>* rgba,
                 std::string* error) {
  jpeg_decompress_struct cinfo;
  JpegErrors errors;
  jpeg_progress_mgr progress;
  cinfo.err = jpeg_std_error(&errors.mgr);
  errors.mgr.error_exit = jpeg_fail;
  errors.mgr.emit_message = jpeg_warning;
  errors.message[0] = '\0';
  if (setjmp(errors.jump)) {
    *error = std::string("cannot decode image: JPEG: ") + errors.message;
    jpeg_destroy_decompress(&cinfo);
    return false;
  }
  jpeg_create_decompress(&cinfo);
  progress.progress_monitor = jpeg_progress;
  cinfo.progress = &progress;
  jpeg_mem_src(&cinfo, data, static_cast<unsigned long>(size));
  jpeg_read_header(&cinfo, TRUE);
  *w = int(std::min<JDIMENSION>(cinfo.image_width, JPEG_MAX_DIMENSION));
  *h = int(std::min<JDIMENSION>(cinfo.image_height, JPEG_MAX_DIMENSION));
  if (!rgba) {
    jpeg_destroy_decompress(&cinfo);
    return true;
  }
  if (cinfo.image_width > JPEG_MAX_DIMENSION || cinfo.image_height > JPEG_MAX_DIMENSION ||
      !size_ok(int(cinfo.image_width), int(cinfo.image_height), error) ||
      !memory_ok(int(cinfo.image_width), int(cinfo.image_height), want_float, error)) {
    jpeg_destroy_decompress(&cinfo);
    return false;
  }
  cinfo.out_color_space = JCS_EXT_RGBA;  // grey and YCbCr to RGB, alpha 255 (CMYK: an error)
  jpeg_start_decompress(&cinfo);
  *w = int(cinfo.output_width);
  *h = int(cinfo.output_height);
  rgba->resize(size_t(*w) * size_t(*h) * 4);
  while (cinfo.output_scanline < cinfo.output_height) {
    JSAMPROW row = rgba->data() + size_t(cinfo.output_scanline) * size_t(*w) * 4;
    jpeg_read_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_decompress(&cinfo);
  jpeg_destroy_decompress(&cinfo);
  return true;
}

}  // namespace

bool exr_header_parsable(const uint8_t* data, size_t size, std::string* why) {
  if (size < 8) return true;
  const bool tiled_file = (data[5] & 0x2) != 0, multipart = (data[5] & 0x10) != 0, deep = (data[5] & 0x8) != 0;
  size_t p = 8, left = size - 8;
  bool tiled = false;
  std::string type;
  // Where tinyexr's walk fails it still converts what it read so far (ParseEXRHeaderFromMemory calls
  // ConvertHeader either way): the checks below apply to the attributes before the bad one.
  for (int n = 0; n < 1024 && left > 0 && data[p] != 0; ++n) {  // an empty name ends the header
    const char* at = reinterpret_cast<const char*>(data + p);
    const size_t name_len = strnlen(at, left);
    if (name_len == left) break;
    const size_t type_len = strnlen(at + name_len + 1, left - name_len - 1);
    if (type_len == left - name_len - 1) break;
    const size_t head = name_len + 1 + type_len + 1;
    if (left - head < 4) break;
    uint32_t len = 0;
    std::memcpy(&len, data + p + head, 4);  // little-endian, as the hosts we build for
    if (len > left - head - 4) break;
    const std::string name(at, name_len), attr_type(at + name_len + 1, type_len);
    if (len == 0 && attr_type != "string") break;  // tinyexr stops there too
    const uint8_t* value = data + p + head + 4;
    if (name == "tiles" && (tiled_file || multipart || deep)) {
      if (len != 9) {
        *why = "a 'tiles' attribute of " + std::to_string(len) + " bytes (9 expected)";
        return false;
      }
      if ((value[8] & 0x3) == 3) {
        *why = "an unknown tile level mode (3)";
        return false;
      }
      tiled = true;
    } else if (name == "chunkCount" && len >= 4) {
      // A scanline file's offset table has chunkCount entries of 8 bytes, which tinyexr allocates before it reads
      // them: a count the file cannot hold would only allocate (0x3f800000 asked for 8.5 GB; found by fuzz_image).
      int32_t chunks = 0;
      std::memcpy(&chunks, value, 4);
      if (chunks > 0 && uint64_t(chunks) * 8u > size) {
        *why = "a chunkCount of " + std::to_string(chunks) + " in a file of " + std::to_string(size) +
               " bytes (8 bytes of offset table a chunk)";
        return false;
      }
    } else if (name == "type" && len > 0 && value[0] != 0) {  // as tinyexr: an empty value leaves the type
      type.assign(reinterpret_cast<const char*>(value), strnlen(reinterpret_cast<const char*>(value), len));
    }
    p += head + 4 + len;
    left -= head + 4 + len;
  }
  if (type.empty()) return true;
  if (type != "scanlineimage" && type != "tiledimage" && type != "deeptile" && type != "deepscanline") {
    std::string shown = type.substr(0, 40);
    for (char& c : shown)
      if (c < 0x20 || c > 0x7e) c = '?';
    *why = "an unknown image type '" + shown + "'";
    return false;
  }
  const bool type_tiled = type == "tiledimage" || type == "deeptile";
  if (type_tiled != tiled) {
    *why = "image type '" + type + "' in a " + (tiled ? "tiled" : "scanline") + " file";
    return false;
  }
  return true;
}

namespace {

// OpenEXR through tinyexr's lower-level calls, whose results are freed on
// every path: its LoadEXRFromMemory leaks the header and the image when a
// file's pixels fail to decode or lack a channel (found by fuzz_image). R, G
// and B channels (or one grey channel), scanline or tiled (level 0); HALF
// read as float, UINT converted.
bool decode_exr(const uint8_t* data, size_t size, DecodedImage* out, std::string* error) {
  EXRVersion version;
  if (ParseEXRVersionFromMemory(&version, data, size) != TINYEXR_SUCCESS) {
    *error = "cannot decode EXR: not an OpenEXR file";
    return false;
  }
  if (version.multipart || version.non_image) {
    *error = "cannot decode EXR: multi-part and deep images are not supported";
    return false;
  }
  // Frees what tinyexr allocated, however decoding ends. The image only when it
  // loaded: a failed LoadEXRImageFromMemory calls FreeEXRImage itself and
  // leaves the freed pointers behind (see below for its channel buffers).
  struct Owned {
    EXRHeader header;
    EXRImage image;
    bool image_loaded = false;
    Owned() {
      InitEXRHeader(&header);
      InitEXRImage(&image);
    }
    ~Owned() {
      if (image_loaded) FreeEXRImage(&image);
      FreeEXRHeader(&header);
    }
  } exr;
  const char* err = nullptr;
  auto fail = [&](const std::string& why) {
    std::string e = err ? std::string(err) : why;  // tinyexr's messages end in (and may hold) newlines
    while (!e.empty() && (e.back() == '\n' || e.back() == ' ')) e.pop_back();
    std::replace(e.begin(), e.end(), '\n', ' ');
    *error = "cannot decode EXR: " + e;
    if (err) FreeEXRErrorMessage(err);
    err = nullptr;
    return false;
  };
  std::string why;
  if (!exr_header_parsable(data, size, &why)) return fail("invalid header: " + why);
  if (ParseEXRHeaderFromMemory(&exr.header, &version, data, size, &err) != TINYEXR_SUCCESS)
    return fail("invalid header");
  EXRHeader& h = exr.header;
  const int64_t w = int64_t(h.data_window.max_x) - h.data_window.min_x + 1;
  const int64_t ht = int64_t(h.data_window.max_y) - h.data_window.min_y + 1;
  if (w <= 0 || ht <= 0 || w > (int64_t(1) << 30) || ht > (int64_t(1) << 30)) return fail("invalid data window");
  if (!size_ok(int(w), int(ht), error) || !memory_ok(int(w), int(ht), true, error)) return false;
  int idx[4] = {-1, -1, -1, -1};  // R, G, B, A
  for (int c = 0; c < h.num_channels; ++c) {
    if (h.pixel_types[c] == TINYEXR_PIXELTYPE_HALF) h.requested_pixel_types[c] = TINYEXR_PIXELTYPE_FLOAT;
    const std::string name = h.channels[c].name;
    const int k = name == "R" ? 0 : name == "G" ? 1 : name == "B" ? 2 : name == "A" ? 3 : -1;
    if (k >= 0) idx[k] = c;
  }
  if (h.num_channels == 1) idx[0] = idx[1] = idx[2] = 0;
  if (idx[0] < 0 || idx[1] < 0 || idx[2] < 0) return fail("no R, G and B channels");
  // tinyexr 1.0.1 sets the image's num_channels only on success, and its clean-up
  // after a failed decode frees num_channels channel buffers: set beforehand,
  // those are freed too instead of leaking (found by fuzz_image; the file is
  // tests/fuzz/regressions/image/exr-leak-on-bad-pixels.exr).
  exr.image.num_channels = h.num_channels;
  if (LoadEXRImageFromMemory(&exr.image, &h, data, size, &err) != TINYEXR_SUCCESS) return fail("invalid pixels");
  exr.image_loaded = true;
  const EXRImage& img = exr.image;
  if (img.width != int(w) || img.height != int(ht)) return fail("inconsistent size");
  auto sample = [&](unsigned char* const* planes, int c, size_t i) -> float {
    if (h.requested_pixel_types[c] == TINYEXR_PIXELTYPE_UINT)
      return float(reinterpret_cast<const uint32_t*>(planes[c])[i]);
    return reinterpret_cast<const float*>(planes[c])[i];
  };
  out->width = int(w);
  out->height = int(ht);
  out->is_float = true;
  out->texels.assign(size_t(w) * size_t(ht) * 16, 0);
  float* rgba = reinterpret_cast<float*>(out->texels.data());
  auto put = [&](unsigned char* const* planes, size_t src, size_t dst) {
    for (int k = 0; k < 3; ++k) rgba[4 * dst + k] = sample(planes, idx[k], src);
    rgba[4 * dst + 3] = idx[3] >= 0 ? sample(planes, idx[3], src) : 1.f;
  };
  if (h.tiled) {
    if (!img.tiles || h.tile_size_x <= 0 || h.tile_size_y <= 0) return fail("invalid tiles");
    for (int t = 0; t < img.num_tiles; ++t) {
      const EXRTile& tile = img.tiles[t];
      if (tile.level_x != 0 || tile.level_y != 0) continue;
      if (!tile.images || tile.width > h.tile_size_x || tile.height > h.tile_size_y) return fail("invalid tile");
      for (int j = 0; j < tile.height; ++j)
        for (int i = 0; i < tile.width; ++i) {
          const int64_t x = int64_t(tile.offset_x) * h.tile_size_x + i, y = int64_t(tile.offset_y) * h.tile_size_y + j;
          if (x < 0 || y < 0 || x >= w || y >= ht) continue;
          put(tile.images, size_t(j) * size_t(h.tile_size_x) + size_t(i), size_t(y) * size_t(w) + size_t(x));
        }
    }
  } else {
    if (!img.images) return fail("no pixels");
    for (size_t i = 0; i < size_t(w) * size_t(ht); ++i) put(img.images, i, i);
  }
  out->repaired_texels = repair_float_texels(out->texels);
  return true;
}

}  // namespace

bool image_dimensions(const uint8_t* data, size_t size, int* w, int* h) {
  if (data == nullptr || size == 0 || size > size_t(1) << 31) return false;
  std::string unused;
  if (is_jpeg(data, size)) return decode_jpeg(data, size, false, w, h, nullptr, &unused);
  if (unsupported_format(data, size)) return false;
  int comp = 0;
  return stbi_info_from_memory(data, int(size), w, h, &comp) != 0;
}

bool is_hdr_path(const std::string& path) {
  std::string e = lower_extension(path);
  return e == "hdr" || e == "exr";
}

bool decode_image_memory(const uint8_t* data, size_t size, bool want_float, DecodedImage* out, std::string* error) {
  *out = DecodedImage();
  if (data == nullptr || size == 0) {
    *error = "empty image data";
    return false;
  }
  if (size > size_t(1) << 31) {
    *error = "image data too large";
    return false;
  }
  if (is_exr(data, size)) {
    if (!want_float) {
      *error = "an EXR (float) image cannot be a colour or data texture";
      return false;
    }
    return decode_exr(data, size, out, error);
  }
  int w = 0, h = 0, comp = 0;
  std::vector<uint8_t> rgba;  // 8-bit images, RGBA
  if (is_jpeg(data, size)) {
    if (!decode_jpeg(data, size, want_float, &w, &h, &rgba, error)) return false;
  } else if (const char* format = unsupported_format(data, size)) {
    *error = std::string("unsupported image format: ") + format + " (textures are PNG, JPEG, TGA, BMP, HDR or EXR)";
    return false;
  } else {
    if (!stbi_info_from_memory(data, int(size), &w, &h, &comp)) {
      const char* why = stbi_failure_reason();
      *error = std::string("cannot decode image: ") + (why ? why : "unknown format");
      return false;
    }
    if (!size_ok(w, h, error) || !memory_ok(w, h, want_float, error)) return false;
    if (stbi_is_hdr_from_memory(data, int(size))) {
      if (!want_float) {
        *error = "an HDR (float) image cannot be a colour or data texture";
        return false;
      }
      if (!hdr_decoder_ends(data, size)) {
        *error = "cannot decode image: bad or truncated run-length data in HDR";
        return false;
      }
      float* f = stbi_loadf_from_memory(data, int(size), &w, &h, &comp, 4);
      if (!f) {
        const char* why = stbi_failure_reason();
        *error = std::string("cannot decode image: ") + (why ? why : "unknown error");
        return false;
      }
      out->texels.resize(size_t(w) * h * 16);
      std::memcpy(out->texels.data(), f, out->texels.size());
      stbi_image_free(f);
      out->repaired_texels = repair_float_texels(out->texels);
      out->width = w;
      out->height = h;
      out->is_float = true;
      return true;
    }
    unsigned char* p = stbi_load_from_memory(data, int(size), &w, &h, &comp, 4);
    if (!p) {
      const char* why = stbi_failure_reason();
      *error = std::string("cannot decode image: ") + (why ? why : "unknown error");
      return false;
    }
    rgba.assign(p, p + size_t(w) * h * 4);
    stbi_image_free(p);
  }
  out->width = w;
  out->height = h;
  out->is_float = want_float;
  if (!want_float) {
    out->texels = std::move(rgba);
    return true;
  }
  // stbi_loadf would linearize 8-bit images with gamma 2.2; decode sRGB exactly instead.
  out->texels.resize(size_t(w) * h * 16);
  float* f = reinterpret_cast<float*>(out->texels.data());
  for (size_t i = 0; i < size_t(w) * h * 4; ++i)
    f[i] = (i % 4 == 3) ? rgba[i] / 255.f : srgb_to_linear(rgba[i] / 255.f);  // as textures decode (core)
  return true;
}

bool decode_image_file(const std::string& path, bool want_float, DecodedImage* out, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = "cannot open the file";
    return false;
  }
  in.seekg(0, std::ios::end);
  std::streamoff n = in.tellg();
  if (n <= 0) {
    *error = "the file is empty";
    return false;
  }
  if (n > (std::streamoff(1) << 31)) {
    *error = "the file is too large";
    return false;
  }
  in.seekg(0);
  std::vector<uint8_t> bytes(static_cast<size_t>(n));
  if (!in.read(reinterpret_cast<char*>(bytes.data()), n)) {
    *error = "cannot read the file";
    return false;
  }
  return decode_image_memory(bytes.data(), bytes.size(), want_float, out, error);
}

}  // namespace pn
