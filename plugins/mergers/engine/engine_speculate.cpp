// The second pass side by side (docs/mergers.md, "Parallel second pass"). The second pass is one
// queue across regions, so its order is the serial one; what runs side by side is the evaluation of
// moves (align, weld, free region, ARAP solve, checks: the expensive part), by speculation. A first
// pass whose candidate pairs all lie in one lane (the unconstrained trial's, which has no regions) is
// one queue with the global check too, and speculates the same way on that lane:
// - when drain pops an entry e to merge and no speculation of it stands, e is evaluated in a batch
//   with up to spec_width_ - 1 entries further down the queue (the look-ahead) whose charts are
//   neither e's nor a standing speculation's nor a neighbour of theirs; each on a lane of its own, all
//   on the atlas as it is, on the thread pool;
// - a move that passes its checks stays in the atlas; one refused is rolled back at once;
// - results are used strictly in queue order: drain goes on exactly as with one thread (pops, lazy
//   refreshes, refusals, commits and the pairs they re-queue), and when it pops an entry that has a
//   standing speculation, that result is used; the global budget is checked then, with the error
//   sum of that moment (check_distortion's own test on the same numbers);
// - a speculation stands while its two charts keep the versions it was evaluated at; it is dropped
//   (rolled back if in the atlas) before drain scores a pair of its charts (scoring reads their UVs)
//   or evaluates an entry sharing one of them.
// Why the result is the one of a single thread: a move reads and writes only its two charts (their
// faces, wedges, grids, boundary, seam), reads other faces' charts only to compare them with its
// own, and the error sum only in the budget test (first-pass lanes rely on the same, see
// first_pass). A move of other charts committed meanwhile changes none of that, so the evaluation
// ahead of time computes what the serial one would compute at its turn, bit for bit.
#include "engine_internal.h"

#include "texdefrag/util/parallel.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <exception>
#include <limits>
#include <mutex>
#include <queue>
#include <thread>

#include <time.h>

namespace texdefrag::merge::detail {

namespace {
/// CPU time of the calling thread.
double thread_cpu_seconds() {
  timespec t{};
  if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t) != 0) return 0;
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}
/// Queue entries the look-ahead examines per batch, best first.
constexpr size_t kLookahead = 256;
/// Speculations standing at once, at most (each holds its rollback log and, if it passed, its move
/// in the atlas).
constexpr size_t kMaxStanding = 16;
}  // namespace

/// Threads kept through the second pass for its batches: a batch of a few moves of a millisecond or
/// less each, thousands of times, where parallel_for would start and join a std::thread per batch
/// (measured: about 0.3 ms of CPU per batch on t016_L19 under load, more than many moves cost).
/// run() is parallel_for's contract: item 0 on the calling thread, the lowest failing item's
/// exception rethrown. Items are claimed one at a time by the caller and by the workers alike, so a
/// worker the scheduler wakes late leaves its item to the caller instead of delaying the batch.
class Engine::BatchPool {
 public:
  explicit BatchPool(int workers) {
    for (int i = 0; i < workers; ++i) threads_.emplace_back([this] { loop(); });
  }
  ~BatchPool() {
    {
      std::lock_guard<std::mutex> lk(m_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
  }
  void run(size_t n, const std::function<void(size_t)>& fn) {
    if (threads_.empty() || n <= 1) {
      for (size_t i = 0; i < n; ++i) fn(i);
      return;
    }
    {
      std::lock_guard<std::mutex> lk(m_);
      fn_ = &fn;
      n_ = n;
      done_ = 0;
      first_failed_ = n;
      error_ = nullptr;
      ++gen_;
      // Item 0 is the caller's; the generation in the high bits keeps a late worker from claiming an
      // item of a later batch.
      next_.store(gen_ << 32 | 1);
    }
    wake_.notify_all();
    work(gen_, 0);
    while (claim(gen_, n)) {
    }
    std::unique_lock<std::mutex> lk(m_);
    finished_.wait(lk, [&] { return done_ == n_; });
    fn_ = nullptr;
    if (error_) std::rethrow_exception(error_);
  }

 private:
  /// Claims the next item of generation g (of n items) and runs it; false when none is left.
  bool claim(unsigned long long g, size_t n) {
    unsigned long long v = next_.load();
    for (;;) {
      if ((v >> 32) != g || (v & 0xffffffffULL) >= n) return false;
      if (next_.compare_exchange_weak(v, v + 1)) break;
    }
    work(g, static_cast<size_t>(v & 0xffffffffULL));
    return true;
  }
  void work(unsigned long long g, size_t i) {
    (void)g;
    // note: items above a failed one are skipped, as in parallel_for.
    if (i <= first_failed_.load()) {
      try {
        (*fn_)(i);
      } catch (...) {
        std::lock_guard<std::mutex> lk(m_);
        if (i < first_failed_.load()) {
          first_failed_.store(i);
          error_ = std::current_exception();
        }
      }
    }
    std::lock_guard<std::mutex> lk(m_);
    if (++done_ == n_) finished_.notify_one();
  }
  void loop() {
    unsigned long long seen = 0;
    for (;;) {
      size_t n;
      {
        std::unique_lock<std::mutex> lk(m_);
        wake_.wait(lk, [&] { return stop_ || gen_ != seen; });
        if (stop_) return;
        seen = gen_;
        n = n_;
      }
      while (claim(seen, n)) {
      }
    }
  }
  std::vector<std::thread> threads_;
  std::mutex m_;
  std::condition_variable wake_, finished_;
  const std::function<void(size_t)>* fn_ = nullptr;
  size_t n_ = 0, done_ = 0;
  unsigned long long gen_ = 0;
  std::atomic<unsigned long long> next_{0};
  std::atomic<size_t> first_failed_{0};
  std::exception_ptr error_;
  bool stop_ = false;
};

void Engine::DeletePool::operator()(BatchPool* p) const { delete p; }

void Engine::start_speculation(Lane& L) {
  // note: only a lane draining alone speculates. The first pass's region lanes drain side by side, so
  // they must not write the engine's shared members (speculating_ is false and stamp_high_ unused
  // there; the second pass starts from the main lane's stamps, the highest of every lane's, join_lanes).
  if (across_ ? &L != &main_ : &L != solo_lane_) return;
  // A solo lane without first_pass_speculation waits for speculate_when's flag (drain asks again).
  speculation_pending_ = !across_ && !opt_.first_pass_speculation && !speculate_when_->load(std::memory_order_relaxed);
  if (speculation_pending_) return;
  speculating_ = spec_width_ > 1 && solver_.reentrant();
  spec_lane_ = &L;
  stamp_high_ = std::max({stamp_high_, L.epoch, L.seen_stamp});
  if (speculating_) pool_.reset(new BatchPool(std::min(thread_count(), spec_width_) - 1));
}

void Engine::stop_speculation(Lane& L) {
  speculation_pending_ = false;
  if (!speculating_) return;
  for (auto& s : spec_)
    if (s->live) drop(*s);
  speculating_ = false;
  spec_lane_ = nullptr;
  pool_.reset();
  // The lane's next stamps must be above every stamp the speculations' lanes left.
  L.epoch = L.seen_stamp = std::max({stamp_high_, L.epoch, L.seen_stamp});
}

void Engine::drop(Speculation& s) {
  if (s.in_atlas) rollback(s.lane);
  s.in_atlas = false;
  s.live = false;
}

void Engine::drop_speculations_of(int a, int b, bool in_atlas_only) {
  for (auto& s : spec_) {
    if (!s->live || (in_atlas_only && !s->in_atlas)) continue;
    const int x = s->e.a, y = s->e.b;
    if (x == a || x == b || y == a || y == b) drop(*s);
  }
}

bool Engine::merge_entry(const Entry& e, std::string& reason, Lane& L, const Lane*& log) {
  log = &L;
  if (!speculating_) return try_merge(e.a, e.b, reason, L);
  for (auto& s : spec_)
    if (s->live && s->e.a == e.a && s->e.b == e.b && s->e.va == e.va && s->e.vb == e.vb) {
      if (repair_skipped_wrongly(*s, L)) {
        drop(*s);  // evaluated afresh below, with the repair
        break;
      }
      ++(across_ ? rep_.second_pass_speculation_used : rep_.first_pass_speculation_used);
      log = &s->lane;
      return settle(*s, reason, L);
    }
  // e's move writes into its charts: no speculation of them may stay in the atlas (and none would
  // stand after e merges). Speculations whose charts changed since are dropped too.
  drop_speculations_of(e.a, e.b, false);
  for (auto& s : spec_)
    if (s->live && (C(s->e.a).version != s->e.va || C(s->e.b).version != s->e.vb)) drop(*s);
  std::vector<Speculation*> batch;
  pick_lookahead(e, batch);
  run_batch(batch);
  log = &batch.front()->lane;
  return settle(*batch.front(), reason, L);
}

Engine::Speculation* Engine::free_slot() {
  for (auto& s : spec_)
    if (!s->live) return s.get();
  spec_.push_back(std::make_unique<Speculation>());
  return spec_.back().get();
}

void Engine::pick_lookahead(const Entry& e, std::vector<Speculation*>& batch) {
  // batch[0] is e itself; its slot is live from now on so free_slot skips it.
  Speculation* first = free_slot();
  first->e = e;
  first->live = true;
  batch.push_back(first);
  std::vector<int> busy{e.a, e.b};
  size_t standing = 0;
  for (const auto& s : spec_)
    if (s->live && s.get() != first) {
      busy.push_back(s->e.a);
      busy.push_back(s->e.b);
      ++standing;
    }
  // Best first over the heap (the children of entry i are 2i + 1 and 2i + 2): the order the pops
  // would take, up to ties and to what the coming merges re-queue. Only a guess: a speculation is
  // used only when drain pops its entry.
  const Lane& L = *spec_lane_;
  const std::vector<Entry>& heap = L.queue.entries();
  std::vector<const Entry*> found;
  std::priority_queue<std::pair<double, size_t>> front;
  if (!heap.empty()) front.emplace(heap[0].score, 0);
  const size_t room = std::min(static_cast<size_t>(spec_width_) - 1, kMaxStanding - std::min(kMaxStanding, standing));
  for (size_t examined = 0; !front.empty() && examined < kLookahead && room > 0; ++examined) {
    const size_t i = front.top().second;
    front.pop();
    for (size_t c = 2 * i + 1; c <= 2 * i + 2 && c < heap.size(); ++c) front.emplace(heap[c].score, c);
    const Entry& x = heap[i];
    if (x.refusal) continue;  // drain refuses it without a move
    const ChartInfo& A = charts_[static_cast<size_t>(x.a)];
    const ChartInfo& B = charts_[static_cast<size_t>(x.b)];
    if (!A.alive || !B.alive || A.version != x.va || B.version != x.vb) continue;  // stale
    const auto ps = L.pairs.find(Lane::pair_key(x.a, x.b));
    if (ps == L.pairs.end() || ps->second.attempts >= opt_.max_attempts) continue;
    found.push_back(&x);
  }
  // Charts disjoint from the busy ones (required). Entries whose charts are not neighbours of them
  // either come first: a merge re-scores its chart's pairs, which drops a neighbour's speculation
  // when its move is in the atlas.
  for (int strict = 1; strict >= 0; --strict)
    for (const Entry* x : found) {
      if (batch.size() > room) return;
      bool clear = true;
      for (int z : busy)
        if (strict ? near_chart(x->a, z) || near_chart(x->b, z) : x->a == z || x->b == z) {
          clear = false;
          break;
        }
      if (!clear) continue;
      Speculation* sp = free_slot();
      sp->e = *x;
      sp->live = true;
      batch.push_back(sp);
      busy.push_back(x->a);
      busy.push_back(x->b);
    }
}

bool Engine::repair_skipped_wrongly(const Speculation& s, const Lane& L) const {
  // note: a move refused as a flip without being solved is one whose solve ended with inverted
  // triangles (check's first test); with the repair on, L's solve would have repaired it.
  // A partial weld's earlier try that needed the repair: L, with the repair spent, would have
  // refused that try as a flip and tried no further.
  if (s.mv.repaired_earlier && repair_spent(L)) return true;
  return s.lane.repair_off && !s.mv.solved && s.reason == "flip" && !repair_spent(L);
}

void Engine::run_batch(std::vector<Speculation*>& batch) {
  for (Speculation* s : batch) {
    Lane& l = s->lane;
    l.rep = MergeReport();
    l.free_total = 0;
    l.free_count = 0;
    // The budget is checked when the result is used: here the lane's sum is 0, so mv.new_sum is the
    // move's change of the sum exactly, and no bound applies.
    l.err_sum = 0;
    l.global_check = false;
    l.err_max = std::numeric_limits<double>::infinity();
    // note: the main lane's repair budget only matters when the result is used (settle refuses a
    // repaired move then); a solve it would refuse is cheaper without the repair (its untangle is most
    // of a large move's cost), and the few whose entry comes when the budget is no longer spent are
    // evaluated again (repair_skipped_wrongly). batch[0] is settled at once: its answer is exact.
    l.repair_off = repair_spent(*spec_lane_);
    // A region's lane refuses repaired moves above repaired_local_bound (check_distortion).
    l.region = spec_lane_->region;
    // Stamps above every earlier one; lanes of one batch share values but touch disjoint charts.
    l.epoch = l.seen_stamp = stamp_high_;
    s->reason.clear();
    s->in_atlas = false;
  }
  std::vector<double> cpu(batch.size(), 0);
  pool_->run(batch.size(), [&](size_t i) {
    const double c0 = thread_cpu_seconds();
    Speculation& s = *batch[i];
    s.mv = Move();
    s.in_atlas = evaluate_merge(s.e.a, s.e.b, s.reason, s.lane, s.mv);
    cpu[i] = thread_cpu_seconds() - c0;
  });
  // On free cores the batch takes at least its longest move and its total over the threads.
  double sum = 0, longest = 0;
  for (double c : cpu) {
    sum += c;
    longest = std::max(longest, c);
  }
  const double threads = static_cast<double>(std::min<size_t>(batch.size(), static_cast<size_t>(thread_count())));
  if (across_) rep_.second_pass_side_cpu_seconds += sum - std::max(longest, sum / threads);
  for (const Speculation* s : batch) stamp_high_ = std::max({stamp_high_, s->lane.epoch, s->lane.seen_stamp});
  (across_ ? rep_.second_pass_speculated : rep_.first_pass_speculated) += batch.size() - 1;
}

bool Engine::settle(Speculation& s, std::string& reason, Lane& L) {
  // What try_merge on L would have returned at this point of the queue: the same checks on the
  // same charts, and the budget test with L's error sum now.
  s.live = false;
  add_counters(L.rep, s.lane.rep);
  L.free_total += s.lane.free_total;
  L.free_count += s.lane.free_count;
  bool ok = s.in_atlas;
  s.in_atlas = false;
  reason = s.reason;
  if (s.mv.repaired && repair_spent(L)) {
    // On L the solve would have skipped the injectivity repair and been refused as a flip; its
    // counters would not show the repair either.
    if (ok) rollback(s.lane);
    --L.rep.repairs_tried;
    if (s.mv.solved) --L.rep.repairs_untangled;
    reason = "flip";
    return false;
  }
  if (s.mv.budget_checked) {
    // note: check_distortion computes L.err_sum + delta; the speculation's lane had err_sum 0, so its
    // new_sum is delta itself and this sum is the same double.
    const double new_sum = L.err_sum + s.mv.new_sum;
    if (const char* why = budget_refusal(L, new_sum, s.mv.repaired)) {
      if (ok) rollback(s.lane);
      reason = why;
      return false;
    }
    s.mv.new_sum = new_sum;
  }
  if (!ok) return false;
  s.mv.lane = &L;
  commit(s.mv);
  return true;
}

}  // namespace texdefrag::merge::detail
