// Fast CDR's deserializer behind field-named, bounds-checked reads of one ROS 2 message.
#include "data/ros2_cdr.hpp"

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/Exception.h>

#include <cstdio>

#include "potmap/error.hpp"

namespace potmap::data {

namespace fcdr = eprosima::fastcdr;

namespace {

std::string hex_byte(std::uint8_t b) {
  char s[8];
  std::snprintf(s, sizeof s, "0x%02x", b);
  return s;
}

}  // namespace

CdrReader::CdrReader(const std::uint8_t* data, std::size_t size, std::string where)
    : where_(std::move(where)), size_(size) {
  // XCDR1's representation identifiers 0x0000 (CDR_BE) and 0x0001 (CDR_LE); Fast CDR alone would
  // also take the parameter-list kinds, whose layout these decoders do not follow.
  if (size < 4)
    throw InputError(where_ + ": message of " + std::to_string(size) +
                     " bytes is shorter than the 4-byte CDR encapsulation header");
  if (data[0] != 0 || data[1] > 1)
    throw InputError(where_ + ": CDR encapsulation " + hex_byte(data[0]) + " " + hex_byte(data[1]) +
                     " at byte 0 is not plain CDR (0x00 0x00 big-endian or 0x00 0x01 "
                     "little-endian)");
  // Fast CDR reads but never writes through this pointer (no serialisation, no resize).
  buffer_ = std::make_unique<fcdr::FastBuffer>(
      reinterpret_cast<char*>(const_cast<std::uint8_t*>(data)), size);
  cdr_ = std::make_unique<fcdr::Cdr>(*buffer_, fcdr::Cdr::DEFAULT_ENDIAN, fcdr::Cdr::DDS_CDR);
  try {
    // Also restarts the alignment after the header, as CDR's encapsulation defines it.
    cdr_->read_encapsulation();
  } catch (const fcdr::exception::Exception& e) {
    fail("encapsulation", e.what());
  }
}

CdrReader::~CdrReader() = default;

std::size_t CdrReader::offset() const {
  return cdr_->getSerializedDataLength();
}

void CdrReader::fail(const char* field, const std::string& why) const {
  throw InputError(where_ + ": field '" + field + "' at byte " + std::to_string(offset()) + " of " +
                   std::to_string(size_) + ": " + why);
}

template <class T>
T CdrReader::read(const char* field) {
  T v{};
  try {
    cdr_->deserialize(v);
  } catch (const fcdr::exception::Exception& e) {
    fail(field, std::string("the message ends (") + e.what() + ")");
  }
  return v;
}

std::uint8_t CdrReader::u8(const char* field) {
  return read<std::uint8_t>(field);
}
std::uint32_t CdrReader::u32(const char* field) {
  return read<std::uint32_t>(field);
}
std::int32_t CdrReader::i32(const char* field) {
  return read<std::int32_t>(field);
}
float CdrReader::f32(const char* field) {
  return read<float>(field);
}
double CdrReader::f64(const char* field) {
  return read<double>(field);
}

std::string CdrReader::str(const char* field) {
  // CDR strings carry their terminating NUL in the length; Fast CDR drops it.
  const std::size_t at = offset();
  std::string s;
  try {
    cdr_->deserialize(s);
  } catch (const fcdr::exception::Exception& e) {
    throw InputError(where_ + ": field '" + field + "' at byte " + std::to_string(at) + " of " +
                     std::to_string(size_) + ": string runs past the message (" + e.what() + ")");
  }
  return s;
}

double CdrReader::stamp(const char* field) {
  const std::int32_t sec = i32(field);
  const std::uint32_t nanosec = u32(field);
  return static_cast<double>(sec) + static_cast<double>(nanosec) * 1e-9;
}

std::uint32_t CdrReader::sequence_length(const char* field, std::size_t min_element_bytes) {
  const std::uint32_t n = u32(field);
  const std::size_t left = size_ - offset();
  if (min_element_bytes > 0 && n > left / min_element_bytes)
    fail(field, "sequence of " + std::to_string(n) + " elements of at least " +
                    std::to_string(min_element_bytes) + " bytes each runs past the " +
                    std::to_string(left) + " bytes left");
  return n;
}

std::vector<float> CdrReader::f32_sequence(const char* field) {
  const std::uint32_t n = sequence_length(field, 4);
  std::vector<float> v(n);
  try {
    if (n > 0) cdr_->deserializeArray(v.data(), n);
  } catch (const fcdr::exception::Exception& e) {
    fail(field, std::string("the message ends (") + e.what() + ")");
  }
  return v;
}

const std::uint8_t* CdrReader::byte_sequence(const char* field, std::size_t& size) {
  size = sequence_length(field, 1);
  const auto* p = reinterpret_cast<const std::uint8_t*>(cdr_->getCurrentPosition());
  if (!cdr_->jump(size)) fail(field, "the message ends");
  return p;
}

}  // namespace potmap::data
