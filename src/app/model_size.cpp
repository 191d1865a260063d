#include "app/model_size.hpp"

#include <cstdio>


namespace peristat {

ModelSize measure(const Model& model, const QuasiStaticProblem& problem, const ModelPart* part) {
  ModelSize s;
  const Ranks& ranks = problem.ranks();
  s.ranks = ranks.size();
  const Particles& p = model.particles;
  s.particles = p.size();
  for (char f : p.fictitious) s.fictitious += f;
  if (part) {  // the whole model's counts: each rank's own particles (rank 0's also those without an owner)
    std::int64_t own = 0, own_fictitious = 0;
    for (std::size_t i = 0; i < part->owner.size(); ++i)
      if (counted_by(part->owner[i], ranks.rank())) {
        ++own;
        own_fictitious += p.fictitious[i];
      }
    s.particles = static_cast<Index>(ranks.sum(std::int64_t{own}));
    s.fictitious = static_cast<Index>(ranks.sum(std::int64_t{own_fictitious}));
    s.part = ranks.size() > 1;  // "in parts": one process's part is the whole model
    s.largest_rank_particles = ranks.max(std::int64_t{p.size()});
  }
  s.bonds = static_cast<long long>(model.n_bonds_whole /
                                   2);  // a rank's part holds some families only
  s.cut_bonds = model.n_cut_bonds;
  s.unknowns = part ? static_cast<Index>(part->n_unknowns_whole) : model.constraints.n_free;
  s.prescribed = 2 * s.particles - s.unknowns;
  // A rank of a distributed run stores its own rows (every rank's pattern is partial then).
  s.nonzeros = problem.pattern().partial ? ranks.sum(std::int64_t{problem.pattern().nonzeros})
                                         : problem.pattern().nonzeros;
  s.correction = problem.surface_correction().method();
  s.correction_stats = problem.surface_correction().stats();
  if (!model.holds_every_family()) {  // each rank counted its own families
    s.bonds_partitioned = ranks.size() > 1;
    s.largest_rank_bonds = ranks.max(std::int64_t{model.bonds.n_bonds()});
    SurfaceCorrectionStats& c = s.correction_stats;
    c.families = static_cast<decltype(c.families)>(ranks.sum(static_cast<std::int64_t>(c.families)));
    c.corrected = static_cast<decltype(c.corrected)>(ranks.sum(static_cast<std::int64_t>(c.corrected)));
    c.clipped = static_cast<decltype(c.clipped)>(ranks.sum(static_cast<std::int64_t>(c.clipped)));
    c.unmatched = static_cast<decltype(c.unmatched)>(ranks.sum(static_cast<std::int64_t>(c.unmatched)));
    c.min_influence = -ranks.max(-c.min_influence);
    c.max_influence = ranks.max(c.max_influence);
    c.seconds = ranks.max(c.seconds);
  }
  s.memory_bytes =
      static_cast<double>(model.memory_bytes() + problem.memory_bytes() + problem.pattern().matrix_bytes());
  return s;
}

void print_size(const ModelSize& s) {
  std::printf("  particles      %d (%d fictitious)\n", s.particles, s.fictitious);
  if (s.part)
    std::printf(
        "                 in parts: a rank holds at most %lld particles, its own and its neighbours "
        "(%.1f%%)\n",
        s.largest_rank_particles, 100.0 * static_cast<double>(s.largest_rank_particles) / s.particles);
  std::printf("  bonds          %lld (%d cut by pre-cracks)\n", s.bonds, s.cut_bonds);
  if (s.bonds_partitioned)
    std::printf(
        "                 partitioned: a rank holds at most %lld of the %lld directed bonds (%.1f%%)\n",
        s.largest_rank_bonds, 2LL * s.bonds,
        100.0 * static_cast<double>(s.largest_rank_bonds) / (2.0 * s.bonds));
  std::printf("  unknowns       %d (%d prescribed components)\n", s.unknowns, s.prescribed);
  if (s.nonzeros > 0)
    std::printf("  tangent        %lld nonzeros\n", s.nonzeros);
  else
    std::printf("  tangent        not assembled (matrix-free: its action is computed)\n");
  if (s.correction == SurfaceCorrectionMethod::moments) {
    const SurfaceCorrectionStats& c = s.correction_stats;
    std::printf("  surface        moments correction: %ld cut families, influence factors %.3g .. %.3g, %ld at a "
                "bound, %ld not matched; %.3f s\n",
                static_cast<long>(c.corrected), c.min_influence, c.max_influence, static_cast<long>(c.clipped),
                static_cast<long>(c.unmatched), c.seconds);
  } else {
    std::printf("  surface        no correction (discretization.surface_correction: none)\n");
  }
  const char* held = s.nonzeros > 0
                         ? (s.ranks > 1 ? "model, problem state and its own rows of the tangent"
                                                 : "model, problem state and tangent")
                         : "model and problem state";
  std::printf("  memory         %.1f MB %s %s (factorisation not included)\n", s.memory_bytes / 1e6,
              s.ranks > 1 ? "on rank 0:" : "for", held);
}

}  // namespace peristat
