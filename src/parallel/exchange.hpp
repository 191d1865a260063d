// Values moved between the ranks by owner: each entry of a vector belongs to one rank, and the
// ranks that read it get the owner's value (DOLFINx's Scatterer, deal.II's ghosted vectors).
// Built on a `Ranks` (MPI, threads or one process), with their buffers owned and counted
// (memory_bytes()). One process: nothing to send, share() returns at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "parallel/ranks.hpp"

namespace peristat {

/// One value per entry of a vector, moved from each entry's owner to the ranks that hold it
/// (which entries, and where they come from, is each implementation's). share() is collective.
class ValueExchange {
 public:
  virtual ~ValueExchange() = default;
  virtual void share(double* x) = 0;
  /// The same for integers (global ids, labels): exact whatever their size.
  virtual void share(std::int64_t* x) = 0;
  /// Bytes of the index lists and buffers.
  virtual std::size_t memory_bytes() const = 0;
};

/// Values that each rank sends to the ranks that read them and receives from the ranks that
/// own them, in one all-to-all per share(): what PartExchange builds.
class Halo : public ValueExchange {
 public:
  /// Collective: this rank's entries that others read go to them; its ghost entries are filled.
  void share(double* x) override { share_as(x, m_send, m_received); }
  void share(std::int64_t* x) override { share_as(x, m_send_ids, m_received_ids); }
  /// Entries share() fills here: this rank's halo.
  std::size_t ghosts() const { return m_recv_index.size(); }
  std::size_t memory_bytes() const override;

 protected:
  explicit Halo(const Ranks& ranks) : m_ranks(&ranks) {}
  /// With m_recv_counts set (per owner rank, the entries this rank receives) and `asked` (what
  /// names them to their owners, grouped by owner): tells every owner what this rank reads
  /// and returns what the others read of this rank's, grouped by reader; sets the send counts
  /// and the buffers.
  std::vector<std::int64_t> ask_owners(const std::vector<std::int64_t>& asked);
  template <class T>
  void share_as(T* x, std::vector<T>& send, std::vector<T>& received);

  const Ranks* m_ranks;
  std::vector<std::int64_t> m_send_counts, m_recv_counts;
  std::vector<std::size_t> m_send_index, m_recv_index;  ///< rank by rank: entries sent, entries filled
  std::vector<double> m_send, m_received;
  std::vector<std::int64_t> m_send_ids, m_received_ids;  ///< made at the first share() of integers
};

/// The ghost tail of a vector over a rank's part of the model (ModelPart): entries
/// [0, n_owned) are this rank's, entry k >= n_owned is the entry of global id ids[k] owned by
/// rank owner[k], where it sits among that rank's first entries. No table over the whole
/// model: the construction sends each owner the ids a rank reads, and every owner finds them
/// among its owned ids, which must ascend. Throws std::logic_error when a rank asks for an id
/// its owner does not own.
class PartExchange : public Halo {
 public:
  PartExchange(const Ranks& ranks, const std::vector<std::int64_t>& ids, const std::vector<int>& owner,
               std::size_t n_owned);
};

/// PartExchange over the entries of a part that have an owner (owner >= 0): one value per
/// particle of a part from its owner into the ranks that read it. The entries without an
/// owner (particles without a row, which every rank holds alike) keep their values. The
/// owned entries come first, as in PartExchange.
class OwnedEntriesExchange final : public ValueExchange {
 public:
  OwnedEntriesExchange(const Ranks& ranks, const std::vector<std::int64_t>& ids, const std::vector<int>& owner,
                       std::size_t n_owned);
  void share(double* x) override { share_as(x, m_scratch); }
  void share(std::int64_t* x) override { share_as(x, m_scratch_ids); }
  std::size_t memory_bytes() const override;

 private:
  template <class T>
  void share_as(T* x, std::vector<T>& scratch);

  std::vector<std::size_t> m_entries;  ///< the entries with an owner
  std::vector<double> m_scratch;
  std::vector<std::int64_t> m_scratch_ids;
  std::unique_ptr<PartExchange> m_exchange;
};

}  // namespace peristat
