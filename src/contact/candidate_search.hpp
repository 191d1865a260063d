// The candidate search of contact (paper section 3; docs/theory/contact.md, section 10): the two
// faces of each pre-crack and declared body interface, the pairs of particles across them in
// the reference configuration, and the partner searches in the current configuration once the
// faces have slid (large sliding). On a rank's part (ContactIds) the pairs that touch its own
// particles, and the check for partners the part does not hold. Geometry only: what a pair
// remembers lives in ContactState.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "contact/contact_ids.hpp"
#include "contact/pair_law.hpp"
#include "core/options.hpp"
#include "core/state_archive.hpp"
#include "core/types.hpp"
#include "discretisation/model.hpp"

namespace peristat {

class CandidateSearch {
 public:
  /// A straight piece of interface with the unit normal pointing from body A into body B.
  struct Segment {
    Vec2 a, b, normal;
  };

  /// `law` sets the band of face particles (delta_c, or one spacing under exact enforcement);
  /// `stiffness` the C of the pairs found. The model, ids and stiffness must outlive the search.
  CandidateSearch(const Model& model, const ContactLaw& law, const ContactIds& ids, const PairStiffness& stiffness);

  /// Builds the faces the options ask for (the model's pre-cracks if options.cracks, declared
  /// interfaces between the model's bodies) and returns the candidate pairs across them in
  /// the reference configuration, ordered by the global ids of their ends. Throws InputError
  /// when a declared interface has no common boundary.
  std::vector<ContactPair> find_reference_pairs(const ContactOptions& options);
  /// Searches the faces for partners in the current configuration u: every pair of particles
  /// of the two sides within one horizon plus one spacing of each other (crack faces: unless
  /// bonded) that is not in `known` is returned, in the order found. u becomes the
  /// configuration of the last search.
  std::vector<ContactPair> find_partners(const std::vector<ContactPair>& known, const VectorXd& u);

  /// Faces to search (a pre-crack or a declared interface).
  bool has_faces() const { return !m_surfaces.empty(); }
  /// The relative tangential motion t.(du_j - du_i) of pair c since the last search [m].
  double slide(const ContactPair& c, const VectorXd& u) const;
  /// The slide after which a search is due (kSearchSlide spacings).
  double slide_trigger() const { return m_search_slide; }
  /// The slide after which a search misses a partner that could already face a particle:
  /// the search radius less the window's reach (sqrt 2 dx) and the trigger (section 10).
  double max_slide_between_searches() const;
  /// On a part: the particles of a face (global ids, ascending) within `reach` of one of this
  /// rank's own particles of the other face at u, that this part does not hold (collective:
  /// every rank gathers the ranks' own face particles). Empty on a whole model.
  std::vector<std::int64_t> partners_not_held(const VectorXd& u, double reach) const;
  /// The radius of a partner search (a horizon plus a spacing) [m].
  double search_radius() const { return m_search_radius; }
  /// Searches done so far.
  int searches() const { return m_searches; }

  /// The displacement of the last search and the count of searches into / from a checkpoint,
  /// by global id (collective on a part).
  void save(StateArchive& archive) const;
  void restore(const StateArchive& archive);

 private:
  /// The two faces of a pre-crack or a declared interface, for partner searches.
  struct Surface {
    std::vector<Index> side_a, side_b;  ///< real particles within the band, one list per side
    bool crack = false;                 ///< faces of one body: pairs within a horizon are bonded
    std::vector<Segment> segments;      ///< the crack, or the interface's shared segments
  };
  /// The faces of the pre-cracks and the bonds they cut, both ends within the band.
  void add_crack_faces(std::vector<ContactPair>& out);
  /// The faces of a declared interface and the pairs across it, both ends within the band.
  void add_interface(const ContactInterface& itf, std::vector<ContactPair>& out);
  /// Pair (i, j) ordered by global id with the interface normal oriented along X_j - X_i;
  /// none when it touches none of this part's own particles or is nearly parallel to the
  /// interface.
  std::optional<ContactPair> make_pair(Index i, Index j, const Vec2& normal) const;
  /// The current position X + u of particle q.
  Vec2 current(Index q, const VectorXd& u) const;

  const Model& m_model;
  const ContactIds& m_ids;
  const PairStiffness& m_stiffness;
  double m_band = 0.0;  ///< face particles lie within this distance of the crack or interface [m]
  std::vector<Surface> m_surfaces;
  VectorXd m_u_search;  ///< displacement (2N) at the last partner search
  double m_search_radius = 0.0, m_search_slide = 0.0;
  int m_searches = 0;
};

}  // namespace peristat
