#include <algorithm>
#include <catch2/catch.hpp>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "rangenav/core/types.hpp"
#include "rangenav/io/svg.hpp"
#include "rangenav/scan/laser_scan.hpp"

using namespace rangenav;
using rangenav::io::Style;
using rangenav::io::SvgDrawing;
using rangenav::io::SvgOptions;

namespace {

const double qnan = std::numeric_limits<double>::quiet_NaN();

// ---- a small reader for what the writer produces ---------------------------------------------

struct Tag {
  std::string name;        // "circle", or "/g" for a closing tag
  std::string attributes;  // raw text between the name and '>'
  std::size_t begin;       // offset of '<'
  std::size_t end;         // offset after '>'
};

std::vector<Tag> tags(const std::string& svg) {
  std::vector<Tag> out;
  for (std::size_t i = svg.find('<'); i != std::string::npos; i = svg.find('<', i + 1)) {
    const std::size_t close = svg.find('>', i);
    REQUIRE(close != std::string::npos);
    std::size_t name_end = i + 1;
    while (name_end < close && svg[name_end] != ' ' && svg[name_end] != '/' && svg[name_end] != '>')
      ++name_end;
    if (svg[i + 1] == '/') name_end = close;
    out.push_back({svg.substr(i + 1, name_end - i - 1), svg.substr(name_end, close - name_end), i,
                   close + 1});
  }
  return out;
}

std::vector<Tag> tags_named(const std::string& svg, std::string_view name) {
  std::vector<Tag> out;
  for (const Tag& t : tags(svg))
    if (t.name == name) out.push_back(t);
  return out;
}

std::string attr(const Tag& t, const std::string& name) {
  const std::string key = " " + name + "=\"";
  const std::size_t at = t.attributes.find(key);
  if (at == std::string::npos) return "";
  const std::size_t from = at + key.size();
  return t.attributes.substr(from, t.attributes.find('"', from) - from);
}

double num_attr(const Tag& t, const std::string& name) {
  return std::stod(attr(t, name));
}

std::vector<double> numbers(const std::string& text) {
  std::vector<double> out;
  std::string cleaned = text;
  for (char& c : cleaned)
    if (c == ',' || c == '(' || c == ')' || std::isalpha(static_cast<unsigned char>(c))) c = ' ';
  std::istringstream in(cleaned);
  for (double v; in >> v;)
    out.push_back(v);
  return out;
}

// The coordinates of the dots of a points() path ("M x y h0 M x y h0 ...").
std::vector<double> dots(const std::string& d) {
  std::string cleaned;
  for (std::size_t i = 0; i < d.size(); ++i) {
    if (d.compare(i, 2, "h0") == 0) {
      cleaned += ' ';
      ++i;
    } else {
      cleaned += d[i];
    }
  }
  return numbers(cleaned);
}

std::size_t count(std::string_view text, std::string_view what) {
  std::size_t n = 0;
  for (std::size_t i = text.find(what); i != std::string_view::npos; i = text.find(what, i + 1))
    ++n;
  return n;
}

// Well-formed XML as far as this writer goes: balanced tags, quoted attributes, text and
// attribute values without raw '<' and only the five predefined entities.
void require_well_formed(const std::string& svg) {
  REQUIRE(svg.rfind("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n", 0) == 0);
  std::vector<std::string> open;
  std::size_t roots = 0;
  std::size_t previous_end = 0;
  for (const Tag& t : tags(svg)) {
    const std::string_view between(svg.data() + previous_end, t.begin - previous_end);
    for (std::size_t a = between.find('&'); a != std::string_view::npos;
         a = between.find('&', a + 1)) {
      const auto rest = between.substr(a);
      REQUIRE((rest.starts_with("&amp;") || rest.starts_with("&lt;") || rest.starts_with("&gt;") ||
               rest.starts_with("&quot;") || rest.starts_with("&apos;")));
    }
    previous_end = t.end;
    if (t.name == "?xml") continue;
    REQUIRE(count(t.attributes, "\"") % 2 == 0);
    if (t.name[0] == '/') {
      REQUIRE(!open.empty());
      REQUIRE(open.back() == t.name.substr(1));
      open.pop_back();
    } else if (!t.attributes.ends_with("/")) {
      if (open.empty()) ++roots;
      open.push_back(t.name);
    }
  }
  CHECK(open.empty());
  CHECK(roots == 1);
}

struct ViewBox {
  double x, y, width, height, width_px, height_px;
};

ViewBox view_box(const std::string& svg) {
  const Tag root = tags_named(svg, "svg").at(0);
  const auto v = numbers(attr(root, "viewBox"));
  REQUIRE(v.size() == 4);
  return {v[0], v[1], v[2], v[3], num_attr(root, "width"), num_attr(root, "height")};
}

// The pixel (from the top-left corner of the picture) where a world point lands.
Point2d pixel_of(const ViewBox& vb, const Point2d& world) {
  return {(world.x() - vb.x) * vb.width_px / vb.width,
          (-world.y() - vb.y) * vb.height_px / vb.height};
}

std::string text_of(const std::string& svg, const Tag& open_text) {
  return svg.substr(open_text.end, svg.find("</text>", open_text.end) - open_text.end);
}

// The content between <g id="id"> and its </g> (layers hold no nested groups).
std::string group(const std::string& svg, const std::string& id) {
  const std::string open = "<g id=\"" + id + "\">";
  const std::size_t from = svg.find(open);
  if (from == std::string::npos) return "";
  return svg.substr(from + open.size(), svg.find("</g>", from) - from - open.size());
}

}  // namespace

TEST_CASE("an empty drawing is a valid SVG", "[io][svg]") {
  const SvgDrawing svg;
  CHECK(svg.empty());
  const std::string text = svg.str();
  require_well_formed(text);
  const ViewBox vb = view_box(text);
  CHECK(vb.width_px > 0);
  CHECK(vb.height_px > 0);
  CHECK(vb.width > 0);
  CHECK(vb.height > 0);
  CHECK(count(text, "scale-bar") == 0);
  CHECK(count(text, "legend") == 0);
  CHECK(tags_named(text, "rect").size() == 1);  // the background
  const std::string transparent = SvgDrawing(SvgOptions{.background = "none"}).str();
  require_well_formed(transparent);
  CHECK(tags_named(transparent, "rect").empty());
}

TEST_CASE("the view box fits the content, y is flipped and the picture has size_px", "[io][svg]") {
  SvgDrawing svg;  // 1000 px, 20 px margin
  svg.segment({0, 0}, {10, 5});
  const std::string text = svg.str();
  require_well_formed(text);
  const ViewBox vb = view_box(text);
  // The longer side (10 m) gets 1000 - 2 * 20 = 960 px: 96 px per metre.
  CHECK(vb.width_px == 1000);
  CHECK(vb.width == Approx(1000.0 / 96).margin(1e-3));
  CHECK(vb.width_px / vb.width == Approx(96).epsilon(1e-3));
  CHECK(vb.height_px / vb.height == Approx(96).epsilon(1e-3));
  // Drawing area 5 * 96 + 40 = 520 px high, then one footer row (20 px) and half a margin.
  CHECK(vb.height_px == 550);
  // The content's top-left corner (0, 5) sits one margin inside the picture, (10, 0) at
  // (980, 500): world y up became SVG y down.
  CHECK(pixel_of(vb, {0, 5}).isApprox(Point2d(20, 20), 1e-3));
  CHECK(pixel_of(vb, {10, 0}).isApprox(Point2d(980, 500), 1e-3));
  const auto lines = tags_named(text, "line");
  REQUIRE(lines.size() == 1);
  CHECK(num_attr(lines[0], "x1") == 0);
  CHECK(num_attr(lines[0], "y1") == 0);
  CHECK(num_attr(lines[0], "x2") == 10);
  CHECK(num_attr(lines[0], "y2") == -5);  // flipped
  // A 1 px line is 1/96 m wide in user units.
  CHECK(num_attr(lines[0], "stroke-width") == Approx(1.0 / 96).margin(1e-5));

  // A tall drawing: the longer side is the height now.
  SvgDrawing tall(SvgOptions{.size_px = 500, .margin_px = 0});
  tall.points(std::vector<Point2d>{{0, 0}, {2, 10}});
  const ViewBox tvb = view_box(tall.str());
  CHECK(tvb.height_px == Approx(500 + 20).margin(1));  // + one footer row
  CHECK(tvb.width_px / tvb.width == Approx(50).epsilon(1e-3));
}

TEST_CASE("the scale bar is a round length with its label", "[io][svg]") {
  using rangenav::io::detail::length_label;
  using rangenav::io::detail::nice_length_at_most;
  CHECK(nice_length_at_most(2.5) == 2.0);
  CHECK(nice_length_at_most(7.5) == 5.0);
  CHECK(nice_length_at_most(1.0) == 1.0);
  CHECK(nice_length_at_most(0.999) == Approx(0.5));
  CHECK(nice_length_at_most(25.0) == 20.0);
  CHECK(nice_length_at_most(1999.0) == 1000.0);
  CHECK(length_label(2.0) == "2 m");
  CHECK(length_label(0.5) == "50 cm");
  CHECK(length_label(0.005) == "5 mm");
  CHECK(length_label(5000.0) == "5 km");

  // A quarter of the longer extent, rounded down to 1, 2 or 5 x 10^k.
  struct Case {
    double extent;
    double bar;
    std::string label;
  };
  for (const Case& c : {Case{10, 2, "2 m"}, Case{100, 20, "20 m"}, Case{3, 0.5, "50 cm"},
                        Case{4, 1, "1 m"}, Case{250, 50, "50 m"}}) {
    SvgDrawing svg;
    svg.points(std::vector<Point2d>{{-1, 7}, {-1 + c.extent, 7 + c.extent / 3}});
    const std::string text = svg.str();
    require_well_formed(text);
    const std::string bar = group(text, "scale-bar");
    REQUIRE(!bar.empty());
    const auto path = tags_named(bar, "path");
    REQUIRE(path.size() == 1);
    // The footer is drawn in pixels: d = "M x0 y0 v8 M x0 y H x1 M x1 y0 v8", the bar spans
    // x0..x1 pixels, which is c.bar metres at the drawing's scale.
    const ViewBox vb = view_box(text);
    const auto v = numbers(attr(path[0], "d"));
    REQUIRE(v.size() == 9);
    CHECK((v[5] - v[0]) * vb.width / vb.width_px == Approx(c.bar).epsilon(2e-3));
    const auto label = tags_named(bar, "text");
    REQUIRE(label.size() == 1);
    CHECK(text_of(bar, label[0]) == c.label);
  }
  SvgDrawing without(SvgOptions{.scale_bar = false});
  without.circle({0, 0}, 1.0);
  CHECK(count(without.str(), "scale-bar") == 0);
}

TEST_CASE("every shape becomes one element and non-finite points are skipped", "[io][svg]") {
  SvgDrawing svg;
  std::vector<Point2d> cloud;
  for (int i = 0; i < 100; ++i)
    cloud.emplace_back(0.1 * i, std::sin(0.1 * i));
  cloud[3].x() = qnan;
  cloud[50].y() = std::numeric_limits<double>::infinity();
  cloud[99] = Point2d(qnan, qnan);
  svg.points(cloud, {.stroke = "red"});
  // A polyline with a hole at index 2 becomes two polylines; a lone point after a hole is no line.
  svg.polyline(
      std::vector<Point2d>{{0, 0}, {1, 0}, {qnan, 0}, {2, 0}, {3, 1}, {4, 1}, {qnan, 1}, {5, 5}});
  svg.polygon(std::vector<Point2d>{{0, 0}, {1, 0}, {1, 1}, {qnan, qnan}}, {.fill = "#eee"});
  svg.circle({2, 2}, 0.5, {.fill = "blue"});
  svg.pose({1, 1, std::numbers::pi / 2}, 2.0);
  svg.text({0, -1}, "hello", 14);
  svg.segment({0, 0}, {1, 1});
  CHECK(svg.element_count() == 8);  // the polyline became two
  const std::string text = svg.str();
  require_well_formed(text);
  const std::string content = group(text, "layer_unnamed");
  REQUIRE(tags_named(content, "path").size() == 2);  // the points and the arrow
  const auto points = tags_named(content, "path")[0];
  CHECK(count(attr(points, "d"), "M") == 97);
  CHECK(count(attr(points, "d"), "h0") == 97);
  CHECK(attr(points, "stroke") == "red");
  CHECK(attr(points, "d").rfind("M0 0h0M0.1 -0.1h0", 0) == 0);  // sin(0.1) = 0.0998 -> 0.1
  const auto polylines = tags_named(content, "polyline");
  REQUIRE(polylines.size() == 2);
  CHECK(numbers(attr(polylines[0], "points")) == std::vector<double>{0, 0, 1, 0});
  CHECK(numbers(attr(polylines[1], "points")) == std::vector<double>{2, 0, 3, -1, 4, -1});
  const auto polygons = tags_named(content, "polygon");
  REQUIRE(polygons.size() == 1);
  CHECK(numbers(attr(polygons[0], "points")) == std::vector<double>{0, 0, 1, 0, 1, -1});
  CHECK(attr(polygons[0], "fill") == "#eee");
  const auto circles = tags_named(content, "circle");
  REQUIRE(circles.size() == 1);
  CHECK(num_attr(circles[0], "cx") == 2);
  CHECK(num_attr(circles[0], "cy") == -2);
  CHECK(num_attr(circles[0], "r") == 0.5);
  // The arrow of (1, 1, 90 deg) with length 2 ends at (1, 3).
  const auto arrow = numbers(attr(tags_named(content, "path")[1], "d"));
  REQUIRE(arrow.size() == 10);
  CHECK(arrow[0] == 1);
  CHECK(arrow[1] == -1);
  CHECK(arrow[2] == Approx(1).margin(1e-3));
  CHECK(arrow[3] == Approx(-3).margin(1e-3));
  CHECK((arrow[4] - 1) * (arrow[8] - 1) < 0);  // barbs on both sides of the shaft,
  CHECK(-arrow[5] < 3);                        // behind the tip
  CHECK(-arrow[9] < 3);
  const auto texts = tags_named(content, "text");
  REQUIRE(texts.size() == 1);
  // Text is placed in metres but sized in pixels: the content spans 9.8 m = 960 px.
  const std::string transform = attr(texts[0], "transform");
  CHECK(transform.rfind("translate(0 1) scale(", 0) == 0);
  CHECK(numbers(transform.substr(transform.find("scale"))).at(0) == Approx(9.8 / 960));
  CHECK(attr(texts[0], "font-size") == "14");
  CHECK(text_of(content, texts[0]) == "hello");
  CHECK(tags_named(content, "line").size() == 1);
}

TEST_CASE("trajectories, pose sets and other clouds", "[io][svg]") {
  SvgDrawing svg;
  const std::vector<Pose2d> poses{{0, 0, 0}, {1, 0, 0.1}, {qnan, 0, 0}, {2, 0, 0.2}, {3, 1, 0.3}};
  svg.path(poses);
  svg.poses(poses, 0.5, {.fill = "black"});
  const LaserScand scan(0.0, std::numbers::pi / 2, 0.0, 10.0, {1.0, qnan, 2.0});
  svg.points(scan);  // the valid points only
  svg.points(std::vector<Point3f>{{1, 2, 3}, {4, 5, 6}});
  const std::string text = svg.str();
  require_well_formed(text);
  const auto polylines = tags_named(text, "polyline");
  REQUIRE(polylines.size() == 2);
  CHECK(numbers(attr(polylines[1], "points")) == std::vector<double>{2, 0, 3, -1});
  const auto paths = tags_named(group(text, "layer_unnamed"), "path");
  REQUIRE(paths.size() == 3);
  CHECK(count(attr(paths[0], "d"), "Z") == 4);  // four finite poses, filled heads
  CHECK(dots(attr(paths[1], "d")) == std::vector<double>{1, 0, -2, 0});
  CHECK(dots(attr(paths[2], "d")) == std::vector<double>{1, -2, 4, -5});
}

TEST_CASE("text and colours are escaped, layer names become valid ids", "[io][svg]") {
  SvgDrawing svg;
  svg.layer("walls & <doors>").segment({0, 0}, {1, 0}, {.stroke = "#123456"});
  svg.layer("\"quoted\" name").text({0, 1}, "a<b & \"c\" > 'd'", 12, {.fill = "x\"y"});
  const std::string text = svg.str();
  require_well_formed(text);
  CHECK(count(text, "a&lt;b &amp; &quot;c&quot; &gt; &apos;d&apos;") == 1);
  CHECK(count(text, "fill=\"x&quot;y\"") == 1);
  CHECK(count(text, "<g id=\"walls____doors_\">") == 1);
  CHECK(count(text, "<g id=\"layer__quoted__name\">") == 1);
  // The legend shows the names as given.
  const std::string legend = group(text, "legend");
  const auto labels = tags_named(legend, "text");
  REQUIRE(labels.size() == 2);
  CHECK(text_of(legend, labels[0]) == "walls &amp; &lt;doors&gt;");
  CHECK(text_of(legend, labels[1]) == "&quot;quoted&quot; name");
  CHECK(rangenav::io::detail::escape_xml(std::string("bell\x07")) == "bell?");
}

TEST_CASE("layers group the shapes and the legend shows their colours", "[io][svg]") {
  SvgDrawing svg;
  svg.circle({0, 0}, 1.0);  // before any layer: the unnamed layer, not in the legend
  svg.layer("map").points(std::vector<Point2d>{{0, 0}, {1, 1}}, {.stroke = "gray"});
  svg.layer("robot").pose({0, 0, 0}, 1.0, {.stroke = "crimson"});
  svg.layer("map").segment({0, 0}, {2, 0});  // selects "map" again
  svg.layer("areas").polygon(std::vector<Point2d>{{0, 0}, {1, 0}, {0, 1}},
                             {.stroke = "none", .fill = "green"});
  svg.layer("empty");
  const std::string text = svg.str();
  require_well_formed(text);
  // Groups in the order of first naming.
  const std::size_t unnamed = text.find("<g id=\"layer_unnamed\">");
  const std::size_t map = text.find("<g id=\"map\">");
  const std::size_t robot = text.find("<g id=\"robot\">");
  const std::size_t areas = text.find("<g id=\"areas\">");
  REQUIRE(unnamed != std::string::npos);
  CHECK(unnamed < map);
  CHECK(map < robot);
  CHECK(robot < areas);
  CHECK(tags_named(group(text, "layer_unnamed"), "circle").size() == 1);
  CHECK(tags_named(group(text, "map"), "path").size() == 1);
  CHECK(tags_named(group(text, "map"), "line").size() == 1);
  CHECK(tags_named(group(text, "robot"), "path").size() == 1);
  CHECK(group(text, "empty").find('<') == std::string::npos);
  // Legend: the named layers that hold shapes, each with its first shape's colour.
  // A dot for points, a line for lines, a box for filled areas.
  const std::string legend = group(text, "legend");
  const auto swatches = tags_named(legend, "path");
  const auto boxes = tags_named(legend, "rect");
  const auto labels = tags_named(legend, "text");
  REQUIRE(swatches.size() == 2);
  REQUIRE(boxes.size() == 1);
  REQUIRE(labels.size() == 3);
  CHECK(text_of(legend, labels[0]) == "map");
  CHECK(text_of(legend, labels[1]) == "robot");
  CHECK(text_of(legend, labels[2]) == "areas");
  CHECK(attr(swatches[0], "stroke") == "gray");
  CHECK(attr(swatches[0], "d").ends_with("h0"));
  CHECK(attr(swatches[1], "stroke") == "crimson");
  CHECK(attr(swatches[1], "d").ends_with("h16"));
  CHECK(attr(boxes[0], "fill") == "green");
  CHECK(attr(boxes[0], "stroke") == "none");
  // A line layer without a stroke colour shows its fill.
  SvgDrawing only_fill;
  only_fill.layer("x").polyline(std::vector<Point2d>{{0, 0}, {1, 1}},
                                {.stroke = "none", .fill = "teal"});
  CHECK(attr(tags_named(group(only_fill.str(), "legend"), "path").at(0), "stroke") == "teal");
  // Without the legend there is no legend group.
  SvgDrawing quiet(SvgOptions{.legend = false});
  quiet.layer("map").circle({0, 0}, 1.0);
  CHECK(count(quiet.str(), "id=\"legend\"") == 0);
}

TEST_CASE("font sizes are written in pixels whatever the scale", "[io][svg]") {
  // Renderers hint glyphs at the font size they are given: a font size of 0.1 user units (a
  // drawing of a few metres) comes out garbled in librsvg, so no font size may be that small.
  for (const double extent : {0.01, 1.0, 10.0, 1000.0, 1e5}) {
    SvgDrawing svg;
    svg.layer("a").segment({0, 0}, {extent, extent / 2});
    svg.text({0, 0}, "label", 10);
    const std::string text = svg.str();
    require_well_formed(text);
    std::size_t sizes = 0;
    for (const Tag& t : tags(text)) {
      if (attr(t, "font-size").empty()) continue;
      CHECK(num_attr(t, "font-size") >= 10);
      ++sizes;
    }
    CHECK(sizes == 2);  // the footer and the text
  }
}

TEST_CASE("many legend entries wrap into rows below the drawing", "[io][svg]") {
  SvgDrawing svg(SvgOptions{.size_px = 300});
  for (int i = 0; i < 12; ++i)
    svg.layer("layer number " + std::to_string(i)).circle({double(i), 0.0}, 0.4);
  const std::string text = svg.str();
  require_well_formed(text);
  const ViewBox vb = view_box(text);
  const std::string legend = group(text, "legend");
  const auto labels = tags_named(legend, "text");
  REQUIRE(labels.size() == 12);
  // 11.8 m x 0.8 m drawn 260 px wide: the drawing area is 0.8 * 260 / 11.8 + 40 px high.
  const double drawing_px = 0.8 * 260 / 11.8 + 40;
  std::vector<double> rows;
  for (const Tag& label : labels) {
    const Point2d px(num_attr(label, "x"), num_attr(label, "y"));  // the footer is in pixels
    CHECK(px.x() >= 0);
    CHECK(px.x() + 7 * 15 <= vb.width_px);  // "layer number 11" fits in the picture
    CHECK(px.y() > drawing_px);
    CHECK(px.y() < vb.height_px);
    if (std::none_of(rows.begin(), rows.end(), [&](double y) { return std::abs(y - px.y()) < 1; }))
      rows.push_back(px.y());
  }
  CHECK(rows.size() >= 4);
  CHECK(vb.height_px == Approx(std::ceil(drawing_px + 20.0 * double(rows.size()) + 10)));
}

TEST_CASE("numbers stay compact: 100k points in about 2 MB", "[io][svg]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coordinate(-50.0, 50.0);
  std::vector<Point2d> cloud(100000);
  for (auto& p : cloud)
    p = Point2d(coordinate(rng), coordinate(rng));
  SvgDrawing svg;
  svg.points(cloud);
  const std::string text = svg.str();
  CHECK(count(text, "h0") == cloud.size());
  CHECK(text.size() < 2'200'000);
  // 9.6 px per metre: two decimals (1 cm = 0.1 px) are written, no more.
  const std::size_t first = text.find("<path d=\"M") + 10;
  const std::string first_x = text.substr(first, text.find(' ', first) - first);
  const std::size_t dot = first_x.find('.');
  CHECK((dot == std::string::npos || first_x.size() - dot - 1 <= 2));
  CHECK(std::stod(first_x) == Approx(cloud[0].x()).margin(0.005));
}

TEST_CASE("save writes the document and names the file on failure", "[io][svg]") {
  SvgDrawing svg;
  svg.circle({1, 1}, 2.0);
  const auto file = std::filesystem::temp_directory_path() / "rangenav_test_svg_save.svg";
  svg.save(file);
  std::ifstream in(file, std::ios::binary);
  const std::string written((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK(written == svg.str());
  std::filesystem::remove(file);
  CHECK_THROWS_WITH(svg.save("/nonexistent-rangenav-dir/a.svg"),
                    "rangenav: SvgDrawing::save: cannot open '/nonexistent-rangenav-dir/a.svg' "
                    "for writing");
  CHECK_THROWS_AS(svg.save("/nonexistent-rangenav-dir/a.svg"), io_error);
}

TEST_CASE("bad arguments throw invalid_argument naming them", "[io][svg]") {
  SvgDrawing svg;
  CHECK_THROWS_WITH(
      svg.circle({0, 0}, -1.0),
      "rangenav: SvgDrawing::circle: argument 'radius_m' = -1 must be finite and >= 0");
  CHECK_THROWS_WITH(svg.circle({qnan, 0}, 1.0),
                    "rangenav: SvgDrawing::circle: argument 'center' = (nan, 0) must be finite");
  CHECK_THROWS_WITH(svg.pose({0, qnan, 0}, 1.0),
                    "rangenav: SvgDrawing::pose: argument 'pose' = (0, nan, 0) must be finite");
  CHECK_THROWS_WITH(svg.pose({0, 0, 0}, 0.0),
                    "rangenav: SvgDrawing::pose: argument 'length_m' = 0 must be finite and > 0");
  CHECK_THROWS_WITH(svg.segment({0, 0}, {1, qnan}),
                    "rangenav: SvgDrawing::segment: argument 'b' = (1, nan) must be finite");
  CHECK_THROWS_WITH(
      svg.points(std::vector<Point2d>{{0, 0}}, {.opacity = 1.5}),
      "rangenav: SvgDrawing::points: argument 'style.opacity' = 1.5 must be in [0, 1]");
  CHECK_THROWS_WITH(svg.polyline(std::vector<Point2d>{}, {.stroke_width_px = -2}),
                    "rangenav: SvgDrawing::polyline: argument 'style.stroke_width_px' = -2 must be "
                    "finite and >= 0");
  CHECK_THROWS_WITH(svg.points(std::vector<Point2d>{}, {.point_radius_px = 0}),
                    "rangenav: SvgDrawing::points: argument 'style.point_radius_px' = 0 must be "
                    "finite and > 0");
  CHECK_THROWS_WITH(svg.text({0, 0}, "x", 0.0),
                    "rangenav: SvgDrawing::text: argument 'size_px' = 0 must be finite and > 0");
  CHECK_THROWS_WITH(svg.layer(""), "rangenav: SvgDrawing::layer: the layer name is empty");
  CHECK_THROWS_WITH(SvgDrawing(SvgOptions{.size_px = 30}),
                    "rangenav: SvgDrawing: argument 'options.size_px' = 30 must be finite and >= 2 "
                    "* margin_px + 10 = 50");
  CHECK_THROWS_AS(SvgDrawing(SvgOptions{.margin_px = -1}), invalid_argument);
  CHECK(svg.empty());  // nothing was added by the failed calls
}
