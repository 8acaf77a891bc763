// The .hsm file (docs/MODEL_FORMAT.md): little-endian binary, FNV-1a checksum at the end.
#include "handsteady/hsm_format.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <iterator>
#include <stdexcept>

namespace hs {

void check_stgae_reference(const StgaeConfig& c, const StgaeReference& r, const std::string& source) {
  const size_t frame = static_cast<size_t>(c.joint_count()) * 3;
  if (r.frames != c.window)
    throw InputError(SourceLocation{source, 0, "reference"},
                     "reference has " + std::to_string(r.frames) + " frames, the window is " + std::to_string(c.window));
  if (r.input.size() != frame * static_cast<size_t>(r.frames) || r.denoised.size() != r.input.size())
    throw InputError(SourceLocation{source, 0, "reference"}, "reference input/denoised sizes do not match frames x joints x 3");
  const size_t npred = c.predict ? frame * static_cast<size_t>(c.horizon) : 0;
  if (r.predicted.size() != npred)
    throw InputError(SourceLocation{source, 0, "reference"}, "reference prediction size does not match horizon x joints x 3");
  for (float v : r.denoised)
    if (!std::isfinite(v)) throw InputError(SourceLocation{source, 0, "reference"}, "non-finite reference output");
  for (float v : r.predicted)
    if (!std::isfinite(v)) throw InputError(SourceLocation{source, 0, "reference"}, "non-finite reference output");
}

namespace {

constexpr std::uint8_t kMagic[8] = {'H', 'S', 'M', '1', 0, 0, 0, 0};

std::uint64_t fnv1a(std::span<const std::uint8_t> bytes) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (std::uint8_t b : bytes) {
    h ^= b;
    h *= 0x100000001b3ULL;
  }
  return h;
}

struct Writer {
  std::vector<std::uint8_t> out;
  void bytes(const void* p, size_t n) {
    const auto* b = static_cast<const std::uint8_t*>(p);
    out.insert(out.end(), b, b + n);
  }
  template <class U>
  void le(U v) {
    for (size_t i = 0; i < sizeof(U); ++i) out.push_back(static_cast<std::uint8_t>((static_cast<std::uint64_t>(v) >> (8 * i)) & 0xff));
  }
  void f32s(const std::vector<float>& v) {
    for (float f : v) le(std::bit_cast<std::uint32_t>(f));
  }
};

// Errors name the source, the part being read and the byte offset.
struct Reader {
  std::span<const std::uint8_t> in;
  size_t pos = 0;
  const std::string& source;
  std::string part = "header";
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(SourceLocation{source, 0, part}, what + " (at byte " + std::to_string(pos) + ")");
  }
  void need(size_t n) const {
    if (n > in.size() - pos) fail("file truncated: needs " + std::to_string(n) + " more bytes, " + std::to_string(in.size() - pos) + " left");
  }
  template <class U>
  U le() {
    need(sizeof(U));
    std::uint64_t v = 0;
    for (size_t i = 0; i < sizeof(U); ++i) v |= static_cast<std::uint64_t>(in[pos + i]) << (8 * i);
    pos += sizeof(U);
    return static_cast<U>(v);
  }
  std::string str(size_t n) {
    need(n);
    std::string s(reinterpret_cast<const char*>(in.data() + pos), n);
    pos += n;
    return s;
  }
  void f32s(std::vector<float>& v, size_t n) {
    need(n * 4);  // checked before allocating
    v.resize(n);
    for (size_t i = 0; i < n; ++i) v[i] = std::bit_cast<float>(le<std::uint32_t>());
  }
};

}  // namespace

std::vector<std::uint8_t> serialize_hsm(const StgaeConfig& config, const StgaeWeights& weights,
                                        const StgaeReference& reference) {
  validate_stgae_config(config, "<serialize>");
  check_stgae_weights(config, weights, "<serialize>");
  check_stgae_reference(config, reference, "<serialize>");
  Writer w;
  w.bytes(kMagic, sizeof kMagic);
  w.le<std::uint32_t>(kHsmVersion);
  const std::string cj = to_json(config);
  w.le<std::uint32_t>(static_cast<std::uint32_t>(cj.size()));
  w.bytes(cj.data(), cj.size());
  const auto specs = stgae_tensor_specs(config);
  w.le<std::uint32_t>(static_cast<std::uint32_t>(specs.size()));
  for (const auto& s : specs) {
    const Tensor& t = weights.at(s.name);
    w.le<std::uint16_t>(static_cast<std::uint16_t>(s.name.size()));
    w.bytes(s.name.data(), s.name.size());
    w.le<std::uint8_t>(0);  // dtype f32
    w.le<std::uint8_t>(static_cast<std::uint8_t>(t.shape.size()));
    for (int d : t.shape) w.le<std::uint32_t>(static_cast<std::uint32_t>(d));
    w.f32s(t.data);
  }
  const int N = config.joint_count();
  w.le<std::uint32_t>(static_cast<std::uint32_t>(reference.frames));
  w.le<std::uint32_t>(static_cast<std::uint32_t>(N));
  w.le<std::uint32_t>(static_cast<std::uint32_t>(config.predict ? config.horizon : 0));
  w.f32s(reference.input);
  w.f32s(reference.denoised);
  w.f32s(reference.predicted);
  w.le<std::uint64_t>(fnv1a(w.out));
  return std::move(w.out);
}

void save_hsm(const std::filesystem::path& path, const StgaeConfig& config, const StgaeWeights& weights,
              const StgaeReference& reference) {
  const auto bytes = serialize_hsm(config, weights, reference);
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) throw std::runtime_error("cannot write " + path.string());
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!f) throw std::runtime_error("error writing " + path.string());
}

HsmContents read_hsm(std::span<const std::uint8_t> bytes, const std::string& source) {
  Reader r{bytes, 0, source};
  // Checksum first: any corruption is reported as such rather than as a confusing parse error.
  if (bytes.size() < sizeof kMagic + 4 + 8) r.fail("file truncated: too short for an .hsm file");
  if (!std::equal(std::begin(kMagic), std::end(kMagic), bytes.begin())) r.fail("not an .hsm model file (bad magic)");
  r.pos = sizeof kMagic;
  const auto version = r.le<std::uint32_t>();
  if (version != kHsmVersion)
    r.fail("unsupported .hsm version " + std::to_string(version) + " (this build reads version " + std::to_string(kHsmVersion) + ")");
  {
    Reader tail{bytes, bytes.size() - 8, source, "checksum"};
    const auto stored = tail.le<std::uint64_t>();
    if (stored != fnv1a(bytes.first(bytes.size() - 8))) {
      tail.pos = bytes.size() - 8;
      tail.fail("checksum mismatch: the file is corrupted or truncated");
    }
  }
  r.in = bytes.first(bytes.size() - 8);  // the checksum is not part of the payload

  r.part = "config";
  const auto clen = r.le<std::uint32_t>();
  const std::string cj = r.str(clen);
  HsmContents out;
  out.config = parse_stgae_config(cj, source);
  const StgaeConfig& c = out.config;

  r.part = "tensors";
  const auto specs = stgae_tensor_specs(c);
  const auto count = r.le<std::uint32_t>();
  if (count != specs.size())
    r.fail("expected " + std::to_string(specs.size()) + " tensors for this configuration, the file has " + std::to_string(count));
  for (std::uint32_t i = 0; i < count; ++i) {
    r.part = "tensor #" + std::to_string(i);
    const auto nlen = r.le<std::uint16_t>();
    std::string name = r.str(nlen);
    r.part = name;
    const auto dtype = r.le<std::uint8_t>();
    if (dtype != 0) r.fail("unsupported dtype " + std::to_string(dtype) + " (only 0 = f32)");
    const auto ndim = r.le<std::uint8_t>();
    if (ndim > 8) r.fail("too many dimensions (" + std::to_string(ndim) + ")");
    Tensor t;
    size_t numel = 1;
    for (int d = 0; d < ndim; ++d) {
      const auto dim = r.le<std::uint32_t>();
      if (dim > (1u << 24)) r.fail("dimension too large (" + std::to_string(dim) + ")");
      t.shape.push_back(static_cast<int>(dim));
      numel *= dim;
      if (numel > (size_t{1} << 28)) r.fail("tensor too large");
    }
    const auto spec = std::find_if(specs.begin(), specs.end(), [&](const TensorSpec& s) { return s.name == name; });
    if (spec == specs.end()) r.fail("unexpected tensor '" + name + "' for this configuration");
    if (spec->shape != t.shape) r.fail("wrong shape: expected " + shape_text(spec->shape) + ", got " + shape_text(t.shape));
    if (out.weights.tensors.contains(name)) r.fail("duplicate tensor");
    r.f32s(t.data, numel);
    out.weights.tensors.emplace(std::move(name), std::move(t));
  }
  check_stgae_weights(c, out.weights, source);

  r.part = "reference";
  const int N = c.joint_count();
  const auto frames = r.le<std::uint32_t>();
  const auto joints = r.le<std::uint32_t>();
  const auto pframes = r.le<std::uint32_t>();
  if (frames != static_cast<std::uint32_t>(c.window) || joints != static_cast<std::uint32_t>(N) ||
      pframes != static_cast<std::uint32_t>(c.predict ? c.horizon : 0))
    r.fail("reference shape " + std::to_string(frames) + " x " + std::to_string(joints) + " (+" + std::to_string(pframes) +
           " predicted) does not match the configuration (" + std::to_string(c.window) + " x " + std::to_string(N) + " (+" +
           std::to_string(c.predict ? c.horizon : 0) + "))");
  out.reference.frames = static_cast<int>(frames);
  const size_t fsz = static_cast<size_t>(N) * 3;
  r.f32s(out.reference.input, fsz * frames);
  r.f32s(out.reference.denoised, fsz * frames);
  r.f32s(out.reference.predicted, fsz * pframes);
  if (r.pos != r.in.size()) r.fail(std::to_string(r.in.size() - r.pos) + " unexpected bytes before the checksum");
  check_stgae_reference(c, out.reference, source);
  return out;
}

HsmContents read_hsm_file(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(SourceLocation{path.string(), 0, ""}, "cannot open model file");
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return read_hsm(bytes, path.string());
}

}  // namespace hs
