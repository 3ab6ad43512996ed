#pragma once
// A small XML reader for TexGen's .tg3 files: elements, attributes and their positions. Text
// content, comments, processing instructions, CDATA and DOCTYPE are skipped; the five predefined
// entities and numeric character references are decoded in attribute values. Enough for files
// written by TexGen (TinyXML); not a validating parser.

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace yarnsim::textile {

/// A place in the text: line and column (in bytes), both 1-based.
struct XmlPosition {
  int line = 0;
  int column = 0;
};

struct XmlElement {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attributes; ///< in file order
  /// Where each attribute's value starts (just inside its quotes), parallel to `attributes`.
  std::vector<XmlPosition> value_positions;
  std::vector<XmlElement> children;
  int line = 0;   ///< line of the element's '<', 1-based
  int column = 0; ///< column of the element's '<', 1-based

  XmlPosition position() const { return {line, column}; }
  /// Where the attribute's value starts; the element's position when it has no such attribute.
  XmlPosition position_of(std::string_view key) const;
  /// The attribute's value, or nullptr when absent.
  const std::string* attribute(std::string_view key) const;
  /// Children with the given name, in order.
  std::vector<const XmlElement*> children_named(std::string_view child) const;
  /// The first child with the given name, or nullptr.
  const XmlElement* child(std::string_view child) const;
};

/// Parses a document and returns its root element. Throws InputError
/// ("source:line:col: message") at the first syntax error.
XmlElement parse_xml(std::string_view text, const std::string& source);

} // namespace yarnsim::textile
