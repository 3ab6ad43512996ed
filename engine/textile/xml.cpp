#include "engine/textile/xml.hpp"

#include "engine/model/deck.hpp"

#include <cctype>
#include <cstdlib>
#include <fmt/format.h>

namespace yarnsim::textile {

const std::string* XmlElement::attribute(std::string_view key) const {
  for (const auto& [k, v] : attributes)
    if (k == key)
      return &v;
  return nullptr;
}

XmlPosition XmlElement::position_of(std::string_view key) const {
  for (std::size_t i = 0; i < attributes.size() && i < value_positions.size(); ++i)
    if (attributes[i].first == key)
      return value_positions[i];
  return position();
}

std::vector<const XmlElement*> XmlElement::children_named(std::string_view child) const {
  std::vector<const XmlElement*> out;
  for (const XmlElement& c : children)
    if (c.name == child)
      out.push_back(&c);
  return out;
}

const XmlElement* XmlElement::child(std::string_view child) const {
  for (const XmlElement& c : children)
    if (c.name == child)
      return &c;
  return nullptr;
}

namespace {

class Parser {
public:
  Parser(std::string_view text, const std::string& source) : text_(text), source_(source) {}

  XmlElement document() {
    skip_misc();
    if (at_end())
      fail("expected a root element, found the end of the file");
    if (peek() != '<')
      fail(fmt::format("expected '<' of the root element, found '{}'", peek()));
    XmlElement root = element();
    skip_misc();
    if (!at_end())
      fail("expected the end of the file after the root element");
    return root;
  }

private:
  [[noreturn]] void fail(const std::string& message) const {
    throw InputError({fmt::format("{}:{}:{}: {}", source_, line_, column(), message)});
  }

  int column() const { return static_cast<int>(pos_ - line_start_) + 1; }
  bool at_end() const { return pos_ >= text_.size(); }
  char peek() const { return text_[pos_]; }
  bool starts_with(std::string_view s) const { return text_.substr(pos_).starts_with(s); }
  void advance(std::size_t n = 1) {
    for (std::size_t k = 0; k < n && pos_ < text_.size(); ++k)
      if (text_[pos_++] == '\n') {
        ++line_;
        line_start_ = pos_;
      }
  }
  void skip_space() {
    while (!at_end() && std::isspace(static_cast<unsigned char>(peek())))
      advance();
  }
  /// Skips to just after `end`; an error naming `what` when it never comes.
  void skip_past(std::string_view end, std::string_view what) {
    const std::size_t at = text_.find(end, pos_);
    if (at == std::string_view::npos)
      fail(fmt::format("unterminated {} (no '{}')", what, end));
    advance(at + end.size() - pos_);
  }
  /// Whitespace, comments, processing instructions and DOCTYPE between elements.
  void skip_misc() {
    for (;;) {
      skip_space();
      if (starts_with("<!--"))
        skip_past("-->", "comment");
      else if (starts_with("<?"))
        skip_past("?>", "processing instruction");
      else if (starts_with("<!DOCTYPE"))
        skip_past(">", "DOCTYPE");
      else
        return;
    }
  }

  static bool name_char(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '-' ||
           c == '.';
  }
  std::string name(std::string_view what) {
    const std::size_t start = pos_;
    while (!at_end() && name_char(peek()))
      advance();
    if (pos_ == start)
      fail(
          fmt::format("expected {}, found {}", what,
                      at_end() ? std::string("the end of the file") : fmt::format("'{}'", peek())));
    return std::string(text_.substr(start, pos_ - start));
  }

  std::string decode(std::string_view raw) const {
    std::string out;
    for (std::size_t i = 0; i < raw.size(); ++i) {
      if (raw[i] != '&') {
        out += raw[i];
        continue;
      }
      const std::size_t semi = raw.find(';', i);
      if (semi == std::string_view::npos)
        fail("expected ';' ending an entity reference in an attribute value");
      const std::string_view entity = raw.substr(i + 1, semi - i - 1);
      if (entity == "lt")
        out += '<';
      else if (entity == "gt")
        out += '>';
      else if (entity == "amp")
        out += '&';
      else if (entity == "quot")
        out += '"';
      else if (entity == "apos")
        out += '\'';
      else if (entity.size() > 1 && entity[0] == '#') {
        const bool hex = entity[1] == 'x';
        const long code =
            std::strtol(std::string(entity.substr(hex ? 2 : 1)).c_str(), nullptr, hex ? 16 : 10);
        if (code > 0 && code < 128)
          out += static_cast<char>(code);
        else
          out += '?'; // non-ASCII characters do not occur in the values we read
      } else
        fail(fmt::format("unknown entity '&{};' in an attribute value", entity));
      i = semi;
    }
    return out;
  }

  XmlElement element() {
    XmlElement e;
    e.line = line_;
    e.column = column();
    advance(); // '<'
    e.name = name("an element name");
    for (;;) {
      skip_space();
      if (at_end())
        fail(fmt::format("unterminated start tag <{}>", e.name));
      if (starts_with("/>")) {
        advance(2);
        return e;
      }
      if (peek() == '>') {
        advance();
        break;
      }
      std::string key = name(fmt::format("an attribute name or the end of <{}>", e.name));
      skip_space();
      if (at_end() || peek() != '=')
        fail(fmt::format("expected '=' after attribute '{}'", key));
      advance();
      skip_space();
      if (at_end() || (peek() != '"' && peek() != '\''))
        fail(fmt::format("expected a quoted value for attribute '{}'", key));
      const char quote = peek();
      advance();
      const XmlPosition value_at{line_, column()};
      const std::size_t close = text_.find(quote, pos_);
      if (close == std::string_view::npos)
        fail(fmt::format("unterminated value of attribute '{}'", key));
      const std::string value = decode(text_.substr(pos_, close - pos_));
      advance(close + 1 - pos_);
      if (e.attribute(key) != nullptr)
        fail(fmt::format("attribute '{}' given twice in <{}>", key, e.name));
      e.attributes.emplace_back(std::move(key), value);
      e.value_positions.push_back(value_at);
    }
    // Content: child elements; text is skipped.
    for (;;) {
      while (!at_end() && peek() != '<')
        advance();
      if (at_end())
        fail(fmt::format("expected </{}> closing the element opened at line {}, found the end of "
                         "the file",
                         e.name, e.line));
      if (starts_with("<!--")) {
        skip_past("-->", "comment");
      } else if (starts_with("<![CDATA[")) {
        skip_past("]]>", "CDATA section");
      } else if (starts_with("<?")) {
        skip_past("?>", "processing instruction");
      } else if (starts_with("</")) {
        advance(2);
        const std::string closing = name("an element name after '</'");
        if (closing != e.name)
          fail(fmt::format("expected </{}> closing the element opened at line {}, found </{}>",
                           e.name, e.line, closing));
        skip_space();
        if (at_end() || peek() != '>')
          fail(fmt::format("expected '>' ending </{}>", closing));
        advance();
        return e;
      } else {
        e.children.push_back(element());
      }
    }
  }

  std::string_view text_;
  const std::string& source_;
  std::size_t pos_ = 0;
  std::size_t line_start_ = 0; ///< offset of the first character of the current line
  int line_ = 1;
};

} // namespace

XmlElement parse_xml(std::string_view text, const std::string& source) {
  return Parser(text, source).document();
}

} // namespace yarnsim::textile
