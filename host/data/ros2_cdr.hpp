#pragma once
// One ROS 2 message's CDR body (its 4-byte encapsulation header, then the fields), read field by
// field through eprosima Fast CDR, the library rmw_fastrtps writes it with. Every failure becomes
// an InputError naming the message (`where`), the field and its byte offset in the message.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace eprosima::fastcdr {
class FastBuffer;
class Cdr;
}  // namespace eprosima::fastcdr

namespace potmap::data {

class CdrReader {
 public:
  /// Reads the encapsulation header: plain CDR, big- or little-endian (XCDR1, as ROS 2 writes).
  /// `data` must outlive the reader.
  CdrReader(const std::uint8_t* data, std::size_t size, std::string where);
  ~CdrReader();
  CdrReader(const CdrReader&) = delete;
  CdrReader& operator=(const CdrReader&) = delete;

  std::uint8_t u8(const char* field);
  std::uint32_t u32(const char* field);
  std::int32_t i32(const char* field);
  float f32(const char* field);
  double f64(const char* field);
  std::string str(const char* field);
  /// builtin_interfaces/Time (int32 sec, uint32 nanosec) in seconds.
  double stamp(const char* field);
  /// A sequence's length, checked against the bytes left (each element at least
  /// `min_element_bytes`), so that a corrupt length fails here rather than in an allocation.
  std::uint32_t sequence_length(const char* field, std::size_t min_element_bytes);
  std::vector<float> f32_sequence(const char* field);
  /// A uint8[] sequence, in place (valid while the message's bytes are).
  const std::uint8_t* byte_sequence(const char* field, std::size_t& size);

  /// Byte offset of the next field in the message (the encapsulation header included).
  std::size_t offset() const;
  std::size_t size() const { return size_; }
  const std::string& where() const { return where_; }
  [[noreturn]] void fail(const char* field, const std::string& why) const;

 private:
  template <class T>
  T read(const char* field);

  std::string where_;
  std::size_t size_;
  std::unique_ptr<eprosima::fastcdr::FastBuffer> buffer_;
  std::unique_ptr<eprosima::fastcdr::Cdr> cdr_;
};

}  // namespace potmap::data
