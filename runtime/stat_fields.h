/// @file stat_fields.h
/// @brief A stage's figures declared once. A `*Stats` struct lists its fields with their report names and
/// how two partial figures of a field combine, in a static `fields()`:
///
/// @code
///   struct AxisStats {                  // figures of one axis, merged over the three
///     long pairs = 0;
///     double worst_shift = 0;
///     static constexpr auto fields() {
///       return std::make_tuple(stat("pairs", &AxisStats::pairs, Combine::sum),
///                              stat("worst_shift", &AxisStats::worst_shift, Combine::max));
///     }
///   };
/// @endcode
///
/// From that one list, merge_stats() combines partial figures (per axis, per component) and the binding's
/// put_stats() (graph/stat_metrics.h) writes the node's metrics, so a field declared is a field reported. A
/// field whose type has its own fields() is nested: its fields are merged and reported by their own names. A
/// std::vector of such structs (one per iteration, say) is reported as one array per field. A name with a dot
/// ("phase_seconds.untangle") is reported as a member of an object.
#pragma once

#include <algorithm>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace polyhex {

/// How two partial figures of one field combine in merge_stats().
enum class Combine {
  keep,  ///< not merged: the whole computation sets it once
  sum,   ///< counts and times
  max,   ///< worst cases
  min,
  any,  ///< flags: true when either is
};

template <class S, class T>
struct StatField {
  const char* name;  ///< the metrics key
  T S::*member;
  Combine combine;
};

/// One declared field of S.
template <class S, class T>
constexpr StatField<S, T> stat(const char* name, T S::*member, Combine combine = Combine::keep) {
  return {name, member, combine};
}

template <class T, class = void>
struct has_stat_fields : std::false_type {};
template <class T>
struct has_stat_fields<T, std::void_t<decltype(T::fields())>> : std::true_type {};

template <class T>
struct is_stats_vector : std::false_type {};
template <class T>
struct is_stats_vector<std::vector<T>> : has_stat_fields<T> {};

/// Calls f(field) for every field S declares, in order.
template <class S, class F>
void for_each_stat(F&& f) {
  static_assert(has_stat_fields<S>::value, "S declares no fields()");
  std::apply([&](const auto&... field) { (f(field), ...); }, S::fields());
}

/// Combines `from` into `into`, field by field, by each field's Combine (nested stats recursively).
template <class S>
void merge_stats(S& into, const S& from) {
  for_each_stat<S>([&](const auto& field) {
    auto& a = into.*field.member;
    const auto& b = from.*field.member;
    using T = std::decay_t<decltype(a)>;
    if constexpr (has_stat_fields<T>::value) {
      merge_stats(a, b);
    } else if constexpr (std::is_same_v<T, bool>) {
      if (field.combine == Combine::any) a = a || b;
    } else if constexpr (std::is_arithmetic_v<T>) {
      switch (field.combine) {
        case Combine::sum:
          a += b;
          break;
        case Combine::max:
          a = std::max(a, b);
          break;
        case Combine::min:
          a = std::min(a, b);
          break;
        case Combine::keep:
        case Combine::any:
          break;
      }
    }
  });
}

}  // namespace polyhex
