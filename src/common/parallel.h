#pragma once
// The one place tessref calls TBB's parallel algorithms (parallel_for, parallel_reduce,
// parallel_sort, task_arena::execute). Every call site uses these wrappers, which keep
// TBB's signatures, instead of tbb:: directly.
//
// Why: Debian's libtbb is not instrumented for ThreadSanitizer, so TSan cannot see the
// happens-before edges TBB's scheduler provides (it hands tasks to workers and reports
// them finished through atomics and futexes inside libtbb). Without help, every write a
// worker makes in a body and the caller reads after the call looks like a data race. Under
// TSan only, the wrappers annotate exactly the edges TBB guarantees:
//   fork: the caller releases a per-call token before the call; every body acquires it
//         first thing, so a body sees everything the caller did before the call;
//   join: every body releases a second per-call token when it ends (also by an exception);
//         the caller acquires it after the call returns (a reduction combines its partial
//         values there, see parallel_reduce).
//   spawn: TBB copies the body into each task it splits off and runs the task, perhaps on
//         another worker, after spawning it; each copy releases its own address when built
//         and a body acquires its own address before it reads itself.
// Bodies never acquire the join token, so races between sibling bodies stay visible.
// Outside TSan the wrappers are the plain TBB calls: no cost, byte-identical outputs.

#include <tbb/blocked_range.h>
#include <tbb/blocked_range2d.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>

#include <utility>

#if defined(__SANITIZE_THREAD__)
#define TESSREF_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define TESSREF_TSAN 1
#endif
#endif

#if TESSREF_TSAN
#include <sanitizer/tsan_interface.h>

#include <algorithm>
#include <map>
#include <mutex>
#endif

namespace tessref {

namespace parallel_detail {

#if TESSREF_TSAN
// The two tokens of one call: their addresses are TSan's synchronisation objects. They live
// in the caller's frame, so calls (nested ones too) never share a token and unrelated
// calls are not ordered by accident.
struct Edges {
    char fork = 0;
    char join = 0;
    Edges() { __tsan_release(&fork); }
    // The caller, after TBB returned (or threw): it has waited for every body.
    ~Edges() { __tsan_acquire(&join); }
    Edges(const Edges&) = delete;
    Edges& operator=(const Edges&) = delete;
};

// A body's run: from its start up to its end, however it ends.
class Scope {
public:
    explicit Scope(Edges& edges) : edges_(edges) { __tsan_acquire(&edges.fork); }
    ~Scope() { __tsan_release(&edges_.join); }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

private:
    Edges& edges_;
};

// The third edge TBB provides: a task is spawned after it is built and runs after it is
// taken, possibly by another worker than the one that split it off. TBB copies the body
// into every task it splits off, so each copy releases its own address when built and
// is acquired before it is read. TBB also recycles a finished task's memory for a new
// task on another worker: a copy releases its address when destroyed and a new one
// acquires it before it is built there.
inline void release(const void* object) { __tsan_release(const_cast<void*>(object)); }
inline const void* acquire(const void* object) {
    __tsan_acquire(const_cast<void*>(object));
    return object;
}

template <class Body>
class ForBody {
public:
    ForBody(Edges& edges, const Body& body) : edges_((acquire(this), &edges)), body_(&body) { release(this); }
    ForBody(const ForBody& other)
        : edges_((acquire(this), acquire(&other), other.edges_)), body_(other.body_) {
        release(this);
    }
    ~ForBody() { release(this); }
    ForBody& operator=(const ForBody&) = delete;
    template <class Argument>
    void operator()(const Argument& argument) const {
        acquire(this);
        Scope scope(*edges_);
        (*body_)(argument);
    }

private:
    Edges* edges_;
    const Body* body_;
};

#endif

}  // namespace parallel_detail

// tbb::parallel_for(range, body): blocked_range, blocked_range2d, any TBB range.
template <class Range, class Body>
void parallel_for(const Range& range, const Body& body) {
#if TESSREF_TSAN
    parallel_detail::Edges edges;
    tbb::parallel_for(range, parallel_detail::ForBody<Body>(edges, body));
#else
    tbb::parallel_for(range, body);
#endif
}

// tbb::parallel_for(first, last, f): f(i) for every index in [first, last).
template <class Index, class Function>
void parallel_for(Index first, Index last, const Function& f) {
#if TESSREF_TSAN
    parallel_detail::Edges edges;
    tbb::parallel_for(first, last, parallel_detail::ForBody<Function>(edges, f));
#else
    tbb::parallel_for(first, last, f);
#endif
}

// tbb::parallel_reduce(range, identity, real_body, reduction), the functional form, over
// a range with begin() (blocked_range).
template <class Range, class Value, class RealBody, class Reduction>
Value parallel_reduce(const Range& range, const Value& identity, const RealBody& real_body,
                      const Reduction& reduction) {
#if TESSREF_TSAN
    // TBB's reduction tree stores and combines partial values in its own task nodes after
    // each body returns, outside any annotation. Under TSan the partial values are kept
    // here instead, one per subrange, and combined by the caller after the join in range
    // order: the same result, since TBB's splitting is not fixed either and so every
    // reduction tessref uses must already be associative. The lock orders only the
    // insertion, after each body's own work, so races between bodies stay visible.
    std::mutex mutex;
    std::map<decltype(range.begin()), Value> partials;
    tessref::parallel_for(range, [&](const Range& r) {
        Value value = real_body(r, identity);
        std::lock_guard<std::mutex> lock(mutex);
        partials.emplace(r.begin(), std::move(value));
    });
    Value result = identity;
    for (auto& partial : partials) result = reduction(result, partial.second);
    return result;
#else
    return tbb::parallel_reduce(range, identity, real_body, reduction);
#endif
}

// tbb::parallel_sort. Its internal tasks (partitioning and merging inside TBB's header
// code, handed over by libtbb) cannot be annotated from outside, so under TSan it is
// std::sort. The result is the same: every comparator tessref sorts with is a strict total
// order on the elements (or only equal elements compare equal), which the outputs need
// anyway to be deterministic, so any correct sort yields the same sequence.
template <class RandomIt>
void parallel_sort(RandomIt first, RandomIt last) {
#if TESSREF_TSAN
    std::sort(first, last);
#else
    tbb::parallel_sort(first, last);
#endif
}

template <class RandomIt, class Compare>
void parallel_sort(RandomIt first, RandomIt last, const Compare& less) {
#if TESSREF_TSAN
    std::sort(first, last, less);
#else
    tbb::parallel_sort(first, last, less);
#endif
}

// arena.execute(f). It runs f on the calling thread when that thread gets a slot in the
// arena, but may hand f to one of the arena's threads otherwise and wait: the same fork
// and join edges then.
template <class Function>
void execute(tbb::task_arena& arena, const Function& f) {
#if TESSREF_TSAN
    parallel_detail::Edges edges;
    arena.execute([&] {
        parallel_detail::Scope scope(edges);
        f();
    });
#else
    arena.execute(f);
#endif
}

// The threads a parallel call here may use: the calling arena's, under the process's
// limit (tbb::global_control, as `--threads` sets it). For sizing work, never for results.
inline int worker_threads() {
    const auto limit = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
    const int arena = tbb::this_task_arena::max_concurrency();
    return std::max(1, static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(arena), limit)));
}

}  // namespace tessref
