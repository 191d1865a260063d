#include "io/xdmf.hpp"

#include <cmath>
#include <sstream>
#include <utility>

#include "core/number_text.hpp"
#include "io/layout.hpp"

namespace peristat::io {
namespace {

std::string xml_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

/// Writes the XML of one grid; `h5` is the escaped file name, `n` the particle count.
class GridWriter {
 public:
  GridWriter(std::ostringstream& out, std::string h5, std::size_t n)
      : m_out(out), m_h5(std::move(h5)), m_n(std::to_string(n)) {}

  /// Opens a grid; a step grid carries its load factor as time.
  void begin(const std::string& name, const XdmfStep* step) {
    m_out << "      <Grid Name=\"" << name << "\" GridType=\"Uniform\">\n";
    if (step != nullptr) {
      const double time = std::isfinite(step->time) ? step->time : step->index;
      m_out << "        <Time Value=\"" << shortest_decimal(time) << "\"/>\n";
    }
    m_out << "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << m_n
          << "\" NodesPerElement=\"1\">\n"
          << "          " << int_item(m_n, "/particles/vertex") << "\n"
          << "        </Topology>\n"
          << "        <Geometry GeometryType=\"XY\">\n"
          << "          " << float_item(m_n + " 2", "/particles/position") << "\n"
          << "        </Geometry>\n";
  }

  void particle_scalars() {
    scalar("volume", "/particles/volume", false);
    scalar("body", "/particles/body", true);
    scalar("fictitious", "/particles/fictitious", true);
  }

  void end() { m_out << "      </Grid>\n"; }

  void scalar(const std::string& name, const std::string& dataset, bool is_int) {
    m_out << "        <Attribute Name=\"" << name << "\" AttributeType=\"Scalar\" Center=\"Node\">\n"
          << "          " << (is_int ? int_item(m_n, dataset) : float_item(m_n, dataset)) << "\n"
          << "        </Attribute>\n";
  }

  /// An N x 2 dataset as a vector attribute. ParaView's "XDMF Reader" (Xdmf 2) pads
  /// 2-component vectors with z = 0, so "Warp By Vector" works (checked with ParaView 5.11;
  /// a JOIN/HyperSlab function gave the same result there but was dropped by the Xdmf 3
  /// readers, which read this plain form as a 2-component array).
  void vector2(const std::string& name, const std::string& dataset) {
    m_out << "        <Attribute Name=\"" << name << "\" AttributeType=\"Vector\" Center=\"Node\">\n"
          << "          " << float_item(m_n + " 2", dataset) << "\n"
          << "        </Attribute>\n";
  }

 private:
  std::string float_item(const std::string& dims, const std::string& dataset) const {
    return "<DataItem Dimensions=\"" + dims + "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" +
           m_h5 + ":" + dataset + "</DataItem>";
  }
  std::string int_item(const std::string& dims, const std::string& dataset) const {
    return "<DataItem Dimensions=\"" + dims + "\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">" + m_h5 +
           ":" + dataset + "</DataItem>";
  }

  std::ostringstream& m_out;
  std::string m_h5;
  std::string m_n;
};

}  // namespace

std::string xdmf_document(const std::string& h5_file_name, std::size_t n_particles,
                          const std::vector<XdmfStep>& steps) {
  std::ostringstream out;
  out << "<?xml version=\"1.0\" ?>\n"
      << "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
      << "<Xdmf Version=\"2.0\">\n"
      << "  <Domain>\n";
  GridWriter grid(out, xml_escape(h5_file_name), n_particles);
  if (steps.empty()) {
    // ParaView's XDMF Reader crashes on an empty temporal collection: until the first
    // step is written, describe the reference configuration alone.
    grid.begin("reference", nullptr);
    grid.particle_scalars();
    grid.end();
  } else {
    out << "    <Grid Name=\"load_steps\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    for (const XdmfStep& step : steps) {
      const std::string group = "/steps/" + step_group_name(step.index);
      grid.begin("step_" + step_group_name(step.index), &step);
      grid.vector2("displacement", group + "/displacement");
      if (step.has_damage) grid.scalar("damage", group + "/damage", false);
      if (step.has_contact_force) grid.vector2("contact_force", group + "/contact_force");
      if (step.has_contact_state) grid.scalar("contact_state", group + "/contact_state", true);
      if (step.has_held) grid.scalar("held", group + "/held", true);
      grid.particle_scalars();
      grid.end();
    }
    out << "    </Grid>\n";
  }
  out << "  </Domain>\n"
      << "</Xdmf>\n";
  return out.str();
}

}  // namespace peristat::io
