// The quasi-static peridynamic problem: total energy Pi(u) = sum_i V_i W_i over the bond
// families plus the contact pairs' work, prescribed components eliminated. Residual and
// tangent are its first and second derivatives, assembled in parallel by gathering per
// particle (deterministic, no atomics). The assembler knows indices, not physics: the OSB
// kernel (materials/osb.hpp), the bonds' failure state (materials/bond_failure.hpp) and the
// contact pairs with their history (contact/contact.hpp) live in objects of their own, and so
// do the energy ledger (energy_balance.hpp), the fragments (fragment_tracker.hpp), the damage
// history (damage_history.hpp), the matrix-free action (tangent_action.hpp) and what a rank
// computes (bookkeeping.hpp).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "assembly/bond_preconditioner.hpp"
#include "assembly/bookkeeping.hpp"
#include "assembly/damage_history.hpp"
#include "assembly/energy_balance.hpp"
#include "assembly/fragment_tracker.hpp"
#include "assembly/pattern.hpp"
#include "assembly/problem.hpp"
#include "assembly/pseudo_velocity.hpp"
#include "assembly/rank_exchanges.hpp"
#include "assembly/tangent_action.hpp"
#include "contact/contact.hpp"
#include "core/global_ids.hpp"
#include "core/huge_pages.hpp"
#include "core/options.hpp"
#include "discretisation/model.hpp"
#include "materials/bond_failure.hpp"
#include "materials/family_kernel.hpp"
#include "materials/fragments.hpp"
#include "materials/surface_correction.hpp"
#include "parallel/ranks.hpp"

namespace peristat {

/// What the problem models beyond the bonds: each part is built only when enabled.
struct ProblemOptions {
  ContactOptions contact;                         ///< contact.enabled = false: no candidates, no cost
  FailureOptions failure;                         ///< failure.enabled = false: no failure checks
  BondPreconditionerOptions bond_preconditioner;  ///< used when a solver asks for a preconditioner
  SurfaceCorrectionMethod surface_correction = SurfaceCorrectionMethod::moments;  ///< discretization.surface_correction
  /// solver.linear: matrix_free. The tangent is never assembled: no pattern is built,
  /// make_tangent() gives an empty matrix, evaluate() with K prepares apply_tangent() instead
  /// of writing K (ADR needs the assembled tangent and never sets this).
  bool matrix_free = false;
  /// solver.krylov.factors float (matrix_free only): the action's per-bond factors kept in
  /// single precision, 16 bytes per bond instead of 32 (RunPlan::float_factors).
  bool float_factors = false;
  /// Double factors, and a single-precision copy of them that the Krylov action reads
  /// (TangentAction::set_float_copy; RunPlan::float_copy).
  bool float_copy = false;
  /// The rows this process assembles: a rank of a distributed run holds its part of the model
  /// (global_id below) and writes only its rows of the tangent and of the bond preconditioner
  /// (docs/guide/distributed.md). Every row by default. With the rows split, the problem's
  /// Ranks combine what the rows' evaluations need (sums, maxima, gathers).
  OwnedRows rows;
  /// On a rank's part of the model (ModelPart, docs/guide/distributed.md "The partitioned
  /// model"): per particle of the part its whole model's index (the failure decisions, the
  /// contact pairs, the checkpoint's rows), and the whole model's particle count. Empty: the
  /// particles are the whole model's.
  std::vector<std::int64_t> global_id;
  std::int64_t n_particles_whole = 0;
  /// On a part: the unknowns this rank owns, the first ones of every vector over the
  /// unknowns (-1: the model is whole here), and per unknown its whole model's index. Every
  /// evaluation of a state x imports x's ghost tail from the owners first (RankExchanges), so
  /// a solver need only keep the owned entries right.
  Index owned_unknowns = -1;
  std::vector<std::int64_t> global_unknown;
};

/// Bonds from which a matrix-free problem drops its per-bond tangent factors while the
/// preconditioner is set up (QuasiStaticProblem::suspend_action()): 0.5 GB of them, for one
/// more evaluation of the families per set-up (the 1000 x 1000 plate's four evaluations, 44.6M
/// bonds, take about 5 s). A judgement, not a measured optimum: smaller runs, and crack growth
/// with its many set-ups, keep the factors.
inline constexpr std::size_t kSuspendActionBonds = 16'000'000;

class QuasiStaticProblem final : public Problem,
                                 public PreconditionerSource,
                                 public IrreversibleState,
                                 public PseudoVelocityInput {
 public:
  /// `ranks`: the ranks of the run, the one way to the others (a distributed run's collectives
  /// and exchanges; one process by default).
  QuasiStaticProblem(const Model& model, const ProblemOptions& options, const Ranks& ranks = serial_ranks());
  /// Its parts hold references to its options: it stays where it was built.
  QuasiStaticProblem(const QuasiStaticProblem&) = delete;
  QuasiStaticProblem& operator=(const QuasiStaticProblem&) = delete;

  /// On a part (ProblemOptions::owned_unknowns): norms over the owned entries, summed over the ranks.
  UnknownSpace unknowns() const override;
  /// Also starts a trial of the exact-contact multipliers, predicted from the committed ones.
  void set_load_factor(double lambda) override;
  double load_factor() const override { return m_lambda; }
  void evaluate(const VectorXd& x, VectorXd& r, SparseMatrix* K) override;
  double force_scale() const override { return m_force_scale; }
  SparseMatrix make_tangent() const override {
    return m_options.matrix_free ? SparseMatrix() : m_pattern.make_matrix(m_model.constraints);
  }
  /// True when the tangent is never assembled (ProblemOptions::matrix_free).
  bool matrix_free() const { return m_options.matrix_free; }
  /// Matrix-free, while a solver sets up its preconditioner (LinearSystem::suspend_action):
  /// drops the families' per-bond factors (s_b and k_b, 32 bytes per bond, 16 in float) when the model has
  /// at least kSuspendActionBonds bonds (set_suspend_bonds()) and no bond broke since the
  /// evaluate() with a tangent that made them. False when nothing was dropped.
  bool suspend_action();
  /// Computes the dropped factors again at the state of the evaluate() that made them (kept
  /// when evaluations without a tangent followed), the same bits, and turns them into the
  /// action's form as it did; the last evaluation's force laws and energy stay.
  void resume_action();
  /// Tests: suspend_action()'s threshold (default kSuspendActionBonds).
  void set_suspend_bonds(std::size_t bonds) { m_suspend_bonds = bonds; }
  /// y = K v with K the tangent of the last evaluate() that asked for one, computed from the
  /// families' factored Hessians (bond stiffnesses and dilatation vectors, docs/theory/osb.md
  /// "Assembly") and the contact pairs' Jacobians without forming K: O(bonds) per product,
  /// the same K the assembled path writes (tests MatrixFree.ActionEqualsTheAssembledTangent*).
  /// Distributed (its rows some of the model's): only this rank's rows of y, bit for bit
  /// the whole product's, reading v only at action_reads(); the other rows are zero
  /// (solver.belos.tangent: matrix_free reads its own rows only).
  void apply_tangent(const VectorXd& v, VectorXd& y) override;
  /// Tests: apply_tangent()'s chunks of consecutive families (default: 1024, or a 128th of
  /// the particles when that is more).
  void set_action_chunk(Index chunk) { m_action.set_chunk(chunk); }
  /// Distributed: the unknowns (ascending) whose entries of v the action of this rank's rows
  /// reads: the ghosts of its rows, two horizons deep, with contact partners and mirror
  /// sources. Changes with traits().structure_version. Every unknown in one process.
  std::vector<Index> action_reads() const { return peristat::action_reads(m_model, m_options.rows, m_contact.get()); }
  /// The structure version is the contact candidates' (a partner search that adds pairs grows
  /// the pattern); the tangent is unsymmetric while a pair slips with friction (the Jacobian
  /// of eq 14), constant with linearised kinematics and neither contact nor failure; the
  /// state signature is the contact and friction active set, and the preconditioner's state
  /// adds the broken bonds.
  ProblemTraits traits() const override;
  /// touching_closed with contact (ContactSystem::set_touching_closed). own_rows_only when
  /// distributed (distributed ADR): the residual of this rank's rows only, from the families
  /// of its particles and their neighbours (and of the particles without a row, which every
  /// rank computes); the contact pairs stay whole on every rank. The rows it computes are bit
  /// for bit the whole evaluation's (unit.Assembly.OwnedRows*).
  bool set_evaluation_mode(EvaluationMode mode) override;
  /// This problem: the `bond` preconditioner and the contact pairs' stiffness bound.
  PreconditionerSource* preconditioner_source() override { return this; }
  /// Matrix-free: the evaluations with a tangent that made the families' factors s_b, k_b
  /// and the pairs' stiffnesses. With linearised kinematics they depend on the bonds alone,
  /// and an evaluation at the bonds of the last one keeps them (docs/theory/newton.md,
  /// "Matrix-free").
  long factor_evaluations() const { return m_factor_evaluations; }
  /// Evaluations with a tangent that made the factors of the changed families only
  /// (patch_factors()), bit for bit those of a full evaluation.
  long factor_patches() const { return m_factor_patches; }
  /// The `bond` preconditioner (assembly/bond_preconditioner.hpp), built on first request.
  SparseMatrix make_preconditioner() override;
  void assemble_preconditioner(SparseMatrix& P) override;
  /// P's rows of the contact zone (assembly/contact_zone.hpp) at the state of the last
  /// evaluation, the fragments decoupled as in P; the other rows empty. Pz: empty, or the
  /// matrix of the last call (its pattern is made again when the zone moved). False, Pz untouched,
  /// without contact, with solver.krylov.contact_zone 0, or when the zone is empty or over
  /// its cap, or on a part of a distributed run (its rows are not all here).
  bool assemble_contact_zone(SparseMatrix& Pz);
  /// Every candidate pair, whatever its state: 4 x ContactSystem::stiffness_bound on the two
  /// components of both particles (a 2 x 2 block appears twice in a row, +J and -J).
  void add_stiffness_bound(VectorXd& row_sums) const override;
  void commit(const VectorXd& x) override;
  void hold_increment(VectorXd& dx) const override {
    for (const Index f : m_fragments.unknowns()) dx[f] = 0.0;
  }
  /// This problem when the scene models failure, else null.
  IrreversibleState* irreversible_state() override { return m_failure ? this : nullptr; }
  /// Bond failure: the bonds over the scene's criterion at x break (BondFailure) and join
  /// the contact candidates when the scene models contact. Returns the bonds broken (0
  /// without failure).
  Index advance_irreversible_state(const VectorXd& x, Index at_most = 0) override;
  void revert_irreversible_state() override;
  /// Exact contact enforcement (ContactSystem::update_multipliers).
  ConstraintUpdate update_multipliers(const VectorXd& x) override;
  /// Rejects a state in which a contact pair has crossed (docs/theory/contact.md, section 9),
  /// or whose faces slid further than a partner search covers (section 10).
  /// Also checks that no particle's damage decreased since the last accepted state, and the
  /// energy balance of the bonds over the increment (EnergyBalance). On a rank's part with
  /// contact, throws PartsOutgrown (collectively) when the faces slid past what the parts hold
  /// (ContactSystem::partners_not_held()): `peristat run` grows the parts.
  std::string check_converged_state(const VectorXd& x) override;
  std::vector<std::string> state_checks() const override;

  /// This problem as ADR's pseudo-velocity input when its friction law reads a velocity
  /// (the paper's eq 13), else null.
  PseudoVelocityInput* pseudo_velocity_input() {
    return m_contact && m_contact->wants_velocity() ? this : nullptr;
  }
  /// Expands v (unknowns) to all components, zero on prescribed ones, for the contact pairs.
  void set_velocity(const VectorXd& v) override;

  /// Full displacement (2N, interleaved) of x at the current load factor.
  void expand(const VectorXd& x, VectorXd& u) const { m_model.constraints.expand(x, m_lambda, u); }
  /// Internal force dPi/du of every component (2N) from the last evaluate; on prescribed
  /// components of layers and surface grips these are the reactions (mirror ghosts: see
  /// reaction()).
  const VectorXd& internal_force() const { return m_force; }
  /// The force boundary condition k applies to hold its particles, from the last evaluate:
  /// the sum of dPi/du over the components it prescribes [N]. For layers and surface grips it
  /// is the reaction on the body; for a mirror condition, the force its ghosts take from the
  /// body (pairs between ghosts cancel in the sum). On a part (ProblemOptions::owned_unknowns)
  /// the sum over every rank's own particles: collective.
  Vec2 reaction(std::size_t k) const;
  /// First Piola stress at particle i from the last evaluate, P = sum_b t_b M_b xi_b^T: the
  /// derivative of W with respect to the deformation gradient when the family deforms
  /// homogeneously (docs/theory/osb.md, section 5). Meaningful away from boundaries.
  Mat2 stress(Index i);
  /// Total strain energy Pi [J] of the last evaluate: every family, fictitious ones included
  /// (with mirror conditions, the ghosts' families too).
  double energy() {
    ensure_laws();
    return m_energy;
  }
  /// Evaluations whose bond forces were the kept factors' product (linear_forces()) since the
  /// problem was made.
  long linear_force_evaluations() const { return m_linear_force_evaluations; }
  const Model& model() const { return m_model; }
  /// The rows this process assembles (ProblemOptions::rows).
  const OwnedRows& owned_rows() const { return m_options.rows; }
  /// On a part: fills the ghost tail of a vector over the unknowns from the owners
  /// (RankExchanges::ghosts(); collective).
  void import_ghosts(VectorXd& v) const { m_exchanges.ghosts()->share(v.data()); }
  /// The ranks of the run (one process: SerialRanks).
  const Ranks& ranks() const { return m_ranks; }
  /// The committed state into / from a checkpoint (peristat run --resume): load factor,
  /// energy ledger, broken bonds, contact candidates and their history. restore_state()
  /// expects a fresh problem of the same model and the committed unknowns x.
  void save_state(StateArchive& archive) const;
  void restore_state(const StateArchive& archive, const VectorXd& x);
  /// Fragments (FragmentTracker): particles cut loose from the prescribed displacements by
  /// breaking, held where they were (docs/theory/failure.md, "Fragments").
  Index fragment_particles() const { return m_fragments.particles(); }
  Index fragments() const { return m_fragments.count(); }
  /// Searches of the whole bond graph for fragments so far (FragmentTracker::graph_searches()).
  long fragment_graph_searches() const { return m_fragments.graph_searches(); }
  /// FragmentTracker::contacts() and reaction() at the last evaluation.
  Index fragment_contacts() const { return m_fragments.contacts(m_contact.get()); }
  double fragment_reaction() const { return m_fragments.reaction(); }
  /// With failure: per particle, 1 where it is held as a fragment at the current bonds.
  const std::vector<char>& particles_held() const { return m_fragments.particles_held(); }
  /// The energy ledger up to the last accepted state.
  const EnergyLedger& energy_ledger() const { return m_balance.ledger(); }
  /// The contact candidates and their state, or null when the scene has no contact.
  const ContactSystem* contact() const { return m_contact.get(); }
  /// The bonds' failure state, or null when the scene models no failure.
  const BondFailure* failure() const { return m_failure.get(); }
  /// With failure: the damage of every particle at the last committed state.
  const VectorXd& damage() const { return m_damage.accepted(); }
  /// The families' influence factors (docs/theory/osb.md, section 8).
  const SurfaceCorrection& surface_correction() const { return m_correction; }
  /// Wall time spent building the contact candidates, and evaluating the pairs (summed over
  /// every evaluate so far) [s].
  double contact_setup_seconds() const { return m_timings.contact_setup; }
  double contact_seconds() const { return m_timings.contact; }
  const TangentPattern& pattern() const { return m_pattern; }
  /// Bytes held by the problem's state, its pattern and its physics objects (not the model,
  /// not the matrices handed out).
  std::size_t memory_bytes() const;

 private:
  /// The relative displacements eta_b = u_j - u_i of particle i's bonds from m_u, into
  /// eta[0 .. family size).
  void family_displacements(Index i, Vec2* eta) const;
  /// eta_b = u_j - u_i of bond b, one of particle i's (the last evaluation's u)
  Vec2 bond_displacement(Index i, Index b) const {
    const Index j = m_model.bonds.neighbour[b];
    return Vec2(m_u[2 * j], m_u[2 * j + 1]) - Vec2(m_u[2 * i], m_u[2 * i + 1]);
  }
  void compute_families(bool want_tangent);
  void gather_forces();
  /// The bond forces at m_u from the action's kept factors, f = H u (TangentAction::
  /// bond_forces()), where that is the same function as the families' forces: every body
  /// linearised, the factors made at the current bonds and kept in double, a whole model.
  /// The families' laws and energy are then left behind (ensure_laws()).
  bool linear_forces() const;
  /// The action's factors are those of the current bonds: matrix-free, every body linearised
  /// (the factors depend on the bonds alone), held (not suspended) and made since the bonds
  /// last changed.
  bool factors_current() const;
  /// m_law and m_energy at m_u, when an evaluation by linear_forces() left them behind.
  void ensure_laws();
  /// The norm of m_force over every component; with own rows only, summed over the ranks.
  double force_norm() const;
  /// m_u from the state x: on a part, x's ghost tail imported first (RankExchanges::ghosts()).
  void expand_state(const VectorXd& x);
  /// The families' forces (and with want_tangent their Hessians' factors) at m_u into
  /// m_force and m_energy; on a part: the rank's families, the energy summed over the ranks.
  void bond_forces(bool want_tangent);
  /// On a part: refuses a problem that would read a family the model does not hold.
  void check_partition() const;
  void gather_tangent(SparseMatrix& K) const;
  /// The particles holding a bond of `pairs` (their families change), into m_changed_families.
  void collect_changed_families(const std::vector<std::pair<Index, Index>>& pairs);
  /// Throws ModelLimit (after undoing the round) when a pair of the round has an end among a
  /// mirror condition's ghosts or their images: the reflection cannot follow broken bonds.
  void check_mirror_zone(const std::vector<std::pair<Index, Index>>& broken);
  /// The increment of the energy ledger from the last accepted state to x, whose evaluate()
  /// was the last (may evaluate the bonds at the midpoint, keeping x's forces). Returns why the
  /// energy balance fails, or "" (failures are reported only when `check`).
  std::string measure_increment(const VectorXd& x, bool check);
  /// The per-bond factors (m_s and m_kbond, or m_s32 and m_kbond32) allocated again (zero)
  /// after suspend_action(), or first.
  void restore_action_storage();
  /// m_u, the state of the last evaluate() with a tangent, into m_u_tangent.
  void keep_tangent_state();
  /// The families' factored Hessians of the last evaluate() with a tangent.
  FamilyHessians hessians() {
    return {m_s, m_kbond, m_s32, m_kbond32, m_options.float_factors, m_s_self, m_beta_volume};
  }
  /// The kernel's s_b and k_b of the family of particle i (its bonds from b0): rounded into
  /// m_s32 and m_kbond32 with float factors (from the thread's scratch, `mine`), and s_self
  /// and beta_i V_i from what is kept.
  void keep_factors(Index i, Index b0, Index nb, std::size_t mine, double beta);
  /// Whether the action's factors, made at earlier bonds, can be brought to the current ones
  /// by patch_factors(): double factors of a whole linearised model, held, made once, and
  /// few families changed since (at most an eighth).
  bool can_patch_factors() const;
  /// The factors of the families changed since they were made (m_dirty_families), the pairs'
  /// stiffnesses of their bonds (with the reverse bonds' kernel factors, computed again for
  /// the neighbours' families) and the float copy of both sides: bit for bit what making them
  /// all would give, for a few hundred families instead of every one.
  void patch_factors();
  /// The kernel of particle i's family at m_u into `out` (eta: scratch of the family's size
  /// for its relative displacements): compute_families()'s and patch_factors()'s.
  FamilyResult run_kernel(Index i, Vec2* eta, const FamilyOutputs& out, bool want_tangent) const;

  const Model& m_model;
  ProblemOptions m_options;
  const Ranks& m_ranks;
  RankExchanges m_exchanges;  ///< before the physics objects: they read the exchanges
  Timings m_timings;                         ///< declared first: m_contact's initialiser sets it
  GlobalIds m_ids;                           ///< the particles by global id, for contact and failure
  std::unique_ptr<ContactSystem> m_contact;  ///< null without contact: no candidates, no cost
  std::unique_ptr<BondFailure> m_failure;    ///< null without failure: no checks, no state
  TangentPattern m_pattern;
  std::unique_ptr<BondPreconditioner> m_preconditioner;  ///< built on first request
  std::unique_ptr<BondPreconditioner> m_zone_preconditioner;  ///< the contact zone's rows of it
  std::vector<char> m_zone;                                   ///< the zone it was built for
  std::vector<std::unique_ptr<FamilyKernel>> m_kernels;  ///< per body: its material's kernel
  bool m_small_kinematics;                               ///< every body linearised: the bond tangent is constant
  /// linear_forces() may serve (matrix-free, every body linearised, double factors, one
  /// process's whole model): decided at construction
  bool m_linear_forces_allowed = false;
  bool m_laws_current = true;  ///< m_law and m_energy are m_u's (false after linear forces)
  long m_linear_force_evaluations = 0;
  /// The kernel's bond weights (omega_b w_b, 0 once broken) and weighted volumes.
  SurfaceCorrection m_correction;
  /// What this rank computes: the families and forces its rows read (every one of a whole model).
  RankShare m_share;
  EnergyBalance m_balance;
  DamageHistory m_damage;
  FragmentTracker m_fragments;
  TangentAction m_action;  ///< matrix_free: the product's schedule and what it keeps
  /// Particles whose families changed in the last round of breaking (scratch).
  std::vector<Index> m_changed_families;
  std::vector<char> m_mirror_zone;  ///< per particle, with failure and mirror conditions: ghost or image
  double m_lambda = 0.0;
  double m_committed_lambda = 0.0;  ///< load factor of the last commit()
  bool m_own_rows_only = false;     ///< EvaluationMode::own_rows_only

  // State of the last evaluate.
  VectorXd m_u, m_force;
  VectorXd m_x_ghosts;  ///< on a part: the state with its ghost tail imported (expand_state)
  VectorXd m_velocity;  ///< full pseudo-velocity (velocity-sign friction only)
  VectorXd m_scratch;   ///< the residual of the evaluations the ledger makes
  double m_force_scale = 0.0, m_energy = 0.0;
  std::vector<Vec2> m_eta;                    ///< per bond, with failure: for its criterion
  std::vector<Vec2> m_eta_scratch;            ///< per thread: one family's eta
  std::vector<double> m_extension_scratch;    ///< per thread: one family's extensions
  Index m_largest_family = 0;
  std::vector<Vec2> m_force_scratch;  ///< per thread: one family's t_b M_b
  /// per particle: its family's force law of the last evaluation (the bond forces are
  /// evaluated again from it where needed, not kept per bond)
  std::vector<BondForceLaw> m_law;
  std::vector<char> m_finite;  ///< per body: finite kinematics
  /// per bond: s_b = b_b M_b of the last evaluation with a tangent (FamilyOutputs)
  UnwrittenVector<Vec2> m_s;
  /// per bond: the family's bond stiffness k_b (axial, transverse); with matrix_free, after an
  /// evaluate() with a tangent, the pair's V_i k_b + V_j k_r in the action's form instead
  /// (TangentAction::prepare())
  UnwrittenVector<BondStiffness> m_kbond;
  /// With float factors (ProblemOptions::float_factors) m_s and m_kbond stay empty and these
  /// hold the same in single precision; the kernel writes its double ones into the scratch.
  UnwrittenVector<Float2> m_s32, m_kbond32;
  std::vector<Vec2> m_s_scratch;               ///< per thread, float factors: one family's s_b
  std::vector<BondStiffness> m_kbond_scratch;  ///< per thread, float factors: one family's k_b
  std::vector<Vec2> m_s_self;                  ///< per particle: -sum_b s_b (as kept)
  /// evaluate() calls, and the call of the last one with a tangent (suspend_action() needs
  /// m_u to be that state)
  std::uint64_t m_evaluations = 0, m_tangent_evaluation = 0;
  Index m_tangent_broken = 0;  ///< broken bonds at the last evaluate() with a tangent
  std::size_t m_suspend_bonds = kSuspendActionBonds;
  bool m_action_suspended = false;  ///< m_s and m_kbond dropped (suspend_action())
  long m_factor_evaluations = 0;    ///< factor_evaluations()
  long m_factor_patches = 0;        ///< factor_patches()
  /// The families whose bonds changed since the action's factors were made (sorted, unique
  /// after patch_factors() reads them)
  std::vector<Index> m_dirty_families;
  std::uint64_t m_bonds_version = 0;  ///< counts the changes of the bonds
  /// m_bonds_version when the action's factors were last made (none yet: never equal)
  std::uint64_t m_factors_version = ~std::uint64_t{0};
  /// Above m_suspend_bonds: m_u of the last evaluate() with a tangent, once an evaluation
  /// without one has followed (resume_action() computes the factors there again)
  VectorXd m_u_tangent;
  std::uint64_t m_u_tangent_evaluation = 0;   ///< the evaluate() whose state m_u_tangent is
  std::vector<double> m_beta_volume;          ///< per particle: beta_i V_i
};

}  // namespace peristat
