// OctoMap's .bt from voxel blocks. A node's type: 0 absent, 1 free leaf, 2 occupied leaf, 3
// inner; its two bytes hold the types of children 0-3 and 4-7, two bits each (child c of a node
// is the one whose key has bit x, y, z set as c's bits 0, 1, 2), which is OctoMap's own coding.

#include "potmap/io/octomap_binary.hpp"

#include <algorithm>
#include <array>
#include <numeric>
#include <sstream>

#include "potmap/error.hpp"

namespace potmap {

namespace {

constexpr int kSide = 16;       // voxels a block side (VoxelBlocks::kSide)
constexpr int kBlockBits = 12;  // block keys: voxel keys >> 4, 0 to 4095 on each axis
constexpr std::int64_t kBlockKeyOffset = 2048;  // OctoMap's key of coordinate 0 is 32768

// The type of a parent from its children's: eight leaves of one state prune into one leaf.
std::uint8_t parent_type(const std::array<std::uint8_t, 8>& t) {
  bool any = false, same = true;
  for (int c = 0; c < 8; ++c) {
    any = any || t[c] != 0;
    same = same && t[c] == t[0];
  }
  if (!any) return 0;
  return same && t[0] != 3 ? t[0] : 3;
}

void put_header(const std::array<std::uint8_t, 8>& t, std::string& out) {
  unsigned lo = 0, hi = 0;
  for (int c = 0; c < 4; ++c) {
    lo |= unsigned(t[c]) << (2 * c);
    hi |= unsigned(t[c + 4]) << (2 * c);
  }
  out.push_back(static_cast<char>(lo));
  out.push_back(static_cast<char>(hi));
}

// A block's levels: level L holds (16 >> L)^3 node types, level 0 the voxels.
struct Pyramid {
  std::array<std::vector<std::uint8_t>, 5> level;
  int side(int l) const { return kSide >> l; }
  std::uint8_t at(int l, int i, int j, int k) const {
    const int s = side(l);
    return level[l][std::size_t(i + s * (j + s * k))];
  }
  std::array<std::uint8_t, 8> children(int l, int i, int j, int k) const {
    std::array<std::uint8_t, 8> t;
    for (int c = 0; c < 8; ++c)
      t[c] = at(l - 1, 2 * i + (c & 1), 2 * j + (c >> 1 & 1), 2 * k + (c >> 2 & 1));
    return t;
  }
  // Depth-first bytes of the inner node (l, i, j, k) and its inner descendants.
  void emit(int l, int i, int j, int k, std::string& out) const {
    const std::array<std::uint8_t, 8> t = children(l, i, j, k);
    put_header(t, out);
    for (int c = 0; c < 8; ++c)
      if (t[c] == 3) emit(l - 1, 2 * i + (c & 1), 2 * j + (c >> 1 & 1), 2 * k + (c >> 2 & 1), out);
  }
};

// The upper tree over the blocks (sorted by their Morton keys).
struct Upper {
  const std::vector<std::uint64_t>& morton;  // interleaved block keys, ascending
  const std::vector<std::size_t>& order;     // block of each sorted entry
  const std::vector<OctomapBlockCode>& codes;
  std::uint64_t nodes = 0;
  // The children's ranges of a node at `depth` (0: the root) over sorted entries [a, b).
  std::array<std::size_t, 9> split(int depth, std::size_t a, std::size_t b) const {
    std::array<std::size_t, 9> r;
    r[0] = a;
    const int shift = 3 * (kBlockBits - 1 - depth);
    for (int c = 0; c < 8; ++c)
      r[c + 1] = std::partition_point(morton.begin() + r[c], morton.begin() + b,
                                      [&](std::uint64_t m) { return int(m >> shift & 7) <= c; }) -
                 morton.begin();
    return r;
  }
  std::uint8_t type(int depth, std::size_t a, std::size_t b) const {
    if (a == b) return 0;
    if (depth == kBlockBits) return codes[order[a]].type;
    const auto r = split(depth, a, b);
    std::array<std::uint8_t, 8> t;
    for (int c = 0; c < 8; ++c) t[c] = type(depth + 1, r[c], r[c + 1]);
    return parent_type(t);
  }
  // Writes the inner node over [a, b) and counts the tree's nodes under it.
  void emit(int depth, std::size_t a, std::size_t b, std::string& out) {
    if (depth == kBlockBits) {
      out += codes[order[a]].bytes;
      nodes += codes[order[a]].nodes - 1;
      return;
    }
    const auto r = split(depth, a, b);
    std::array<std::uint8_t, 8> t;
    for (int c = 0; c < 8; ++c) t[c] = type(depth + 1, r[c], r[c + 1]);
    put_header(t, out);
    for (int c = 0; c < 8; ++c) {
      nodes += t[c] != 0;
      if (t[c] == 3) emit(depth + 1, r[c], r[c + 1], out);
    }
  }
};

std::uint64_t interleave(const std::uint32_t key[3]) {
  std::uint64_t m = 0;
  for (int bit = kBlockBits - 1; bit >= 0; --bit)
    for (int d = 2; d >= 0; --d) m = m << 1 | (key[d] >> bit & 1);
  return m;
}

}  // namespace

OctomapBlockCode encode_octomap_block(const OctomapState* states) {
  Pyramid p;
  p.level[0].resize(std::size_t(kSide) * kSide * kSide);
  for (std::size_t v = 0; v < p.level[0].size(); ++v) p.level[0][v] = std::uint8_t(states[v]);
  OctomapBlockCode code;
  for (int l = 1; l <= 4; ++l) {
    const int s = p.side(l);
    p.level[l].resize(std::size_t(s) * s * s);
    for (int k = 0; k < s; ++k)
      for (int j = 0; j < s; ++j)
        for (int i = 0; i < s; ++i) {
          const std::uint8_t t = parent_type(p.children(l, i, j, k));
          p.level[l][std::size_t(i + s * (j + s * k))] = t;
        }
  }
  code.type = p.level[4][0];
  if (code.type == 3) p.emit(4, 0, 0, 0, code.bytes);
  // Every inner node's two bytes name its existing children: the nodes are the block's own
  // and those children.
  code.nodes = code.type == 0 ? 0 : 1;
  for (std::size_t i = 0; i < code.bytes.size(); ++i)
    for (int c = 0; c < 4; ++c)
      code.nodes += (static_cast<unsigned char>(code.bytes[i]) >> (2 * c) & 3) != 0;
  return code;
}

OctomapFile octomap_binary_file(double resolution, const std::vector<std::int64_t>& block_index,
                                const std::vector<OctomapBlockCode>& codes) {
  const std::size_t n = codes.size();
  if (block_index.size() != 3 * n)
    throw ArgumentError("OctoMap file: " + std::to_string(block_index.size()) +
                        " block coordinates for " + std::to_string(n) + " blocks");
  std::vector<std::uint64_t> keys(n);
  for (std::size_t b = 0; b < n; ++b) {
    std::uint32_t key[3];
    for (int d = 0; d < 3; ++d) {
      const std::int64_t k = block_index[3 * b + d] + kBlockKeyOffset;
      if (k < 0 || k >= (std::int64_t(1) << kBlockBits))
        throw ArgumentError("OctoMap file: block " + std::to_string(b) + " lies " +
                            std::to_string(block_index[3 * b + d] * kSide) +
                            " voxels from the origin on axis " + std::to_string(d) +
                            ", beyond OctoMap's 32768");
      key[d] = static_cast<std::uint32_t>(k);
    }
    keys[b] = interleave(key);
  }
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return keys[a] < keys[b]; });
  std::vector<std::uint64_t> morton(n);
  for (std::size_t i = 0; i < n; ++i) morton[i] = keys[order[i]];
  for (std::size_t i = 1; i < n; ++i)
    if (morton[i] == morton[i - 1])
      throw ArgumentError("OctoMap file: block " + std::to_string(order[i]) + " is given twice");

  Upper up{morton, order, codes};
  std::string data;
  // OctoMap never prunes its root: a tree with any node has an inner root.
  if (up.type(0, 0, n) != 0) {
    up.nodes = 1;
    up.emit(0, 0, n, data);
  }
  OctomapFile file;
  file.nodes = up.nodes;
  // Leaves are the children named free or occupied in some inner node's two bytes.
  for (char byte : data)
    for (int c = 0; c < 4; ++c) {
      const unsigned t = static_cast<unsigned char>(byte) >> (2 * c) & 3;
      file.leaves += t == 1 || t == 2;
    }
  std::ostringstream head;
  head << "# Octomap OcTree binary file\n# (feel free to add / change comments, but leave the "
          "first line as it is!)\n#\nid OcTree\nsize "
       << up.nodes << "\nres " << resolution << "\ndata\n";
  file.bytes = head.str() + data;
  return file;
}

}  // namespace potmap
