#pragma once
// Reader of TexGen's .tg3 files (XML written by TexGen, the textile modeller the paper used to
// make its fabric, §4): yarn centre lines to node chains of 3-node beams, sections from the yarn
// sections, one contact spline per yarn. See the "TG3 File Format" page of TexGen's wiki.
//
// What is read:
// - Textiles whose yarns are written out (<Yarn> with <MasterNode Position Tangent Up>,
//   <Interpolation type="CInterpolationBezier" | "CInterpolationCubic" Periodic>, <Repeat>).
//   Bezier: TexGen's cubic Bezier segments, tangents from the file or (next - previous master
//   node), control points at a third of the chord. Cubic: TexGen's per-coordinate cubic spline in
//   a uniform parameter, periodic or natural.
// - Weaves stored as a pattern only (CTextileWeave2D, CTextileWeave3D with <PatternCell>,
//   <XYarnData>, <YYarnData>, GapSize): built as TexGen's weave builder does it, yarns stacked
//   in each cell from z = 0 upward (heights plus GapSize), master nodes at the crossings with
//   in-plane tangents, Bezier interpolation, repeats of the pattern's width and height. Cell
//   entries: 1 = X yarn, 0 = Y yarn, 2 = none, listed from the bottom up. Elliptical sections.
// - Sections (<YarnSection type="CYarnSectionConstant"> holding a <Section>): CSectionEllipse,
//   CSectionLenticular (no distortion), CSectionPowerEllipse, CSectionRectangle; Width and Height
//   are full sizes. For interpolated yarn sections (CYarnSectionInterpNode, ...) the first
//   section stands for the whole yarn. Non-elliptical outlines set the stiffness exactly; their
//   contact geometry is the ellipse of the same width and height (outline_yarn_section).
// - GeometryScale ("mm" when absent, TexGen's default; "cm", "m", "um", "in").
// Not read: the domain (TexGen clips yarns with it for meshing only), fibre distributions,
// section rotation angles.
//
// Yarns: X yarns (end-to-end vector mostly along x) are warp, the others weft; each yarn runs
// from its smaller to its larger end coordinate. Repeats: a periodic yarn whose end-to-end vector
// is one of its Repeat vectors is extended along it (repeats[k] periods in all), any other
// Repeat vector makes repeats[k] parallel copies.

#include "engine/textile/fabric.hpp"

#include <array>
#include <filesystem>
#include <string>
#include <string_view>

namespace yarnsim::textile {

struct TexGenOptions {
  YarnMaterial material;             ///< E or EA, nu or G, density
  double reduce_lower_inertia = 0.1; ///< factor on the lower moment of inertia (paper: 0.1)
  double reduce_upper_inertia = 1.0; ///< factor on the upper one (ellipse_yarn_section)
  double shear_factor = 5.0 / 6.0;
  int elements_per_interval = 4; ///< 3-node elements between neighbouring master nodes
  /// Periods (along the yarn) or copies (across) per Repeat vector of each yarn, in file order;
  /// 1 = the yarn as written.
  std::array<int, 3> repeats{1, 1, 1};
  double length_scale = 0;   ///< m per file unit; 0: from the textile's GeometryScale
  double contact_radius = 0; ///< m; 0: half the section height of each yarn
  InterfaceLawParameters contact_law{1.5e6, 1.0, 0.0}; ///< of the "warp-weft" contact
  /// Which formulation the "warp-weft" contact uses (finish_fabric): the splines (radius
  /// contact_radius) or the surfaces (each yarn's section ellipse: half its Width and Height).
  ContactFormulation contact = ContactFormulation::Spline;
  std::string textile; ///< name of the <Textile> to read; empty: the first one
  /// Build weave textiles from their pattern even when their yarns are written out.
  bool rebuild_weaves = false;
};

/// Reads a .tg3 file. Throws InputError (engine/model/deck.hpp) listing every problem of the file
/// at once, in file order, each as "file:line:col: message" saying what was expected and what was
/// found: missing or malformed attributes (at the attribute's value), missing or unsupported
/// elements and content (at the element's '<'), a weave pattern that does not fit its counts. Each
/// yarn, section, master node and pattern cell is checked whatever its neighbours hold. An XML
/// syntax error stops the reading at its position, as the rest of the file cannot be trusted; a
/// file that cannot be read is one "file: message".
Fabric read_texgen(const std::filesystem::path& file, const TexGenOptions& options);

/// As read_texgen, from text; `source_name` stands for the file name in messages.
Fabric read_texgen_string(std::string_view text, std::string_view source_name,
                          const TexGenOptions& options);

} // namespace yarnsim::textile
