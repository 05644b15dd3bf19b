/// @file stat_metrics.h
/// @brief A binding's metrics from a stats struct declared once (runtime/stat_fields.h): every declared field
/// under its declared name, nested stats flattened, a vector of stats as one array per field, a dotted name
/// as a member of an object.
#pragma once

#include "runtime/stat_fields.h"

#include <nlohmann/json.hpp>

#include <string>

namespace polyhex {

namespace stat_detail {
/// The JSON slot of a declared name: j[name], or j[a][b] for "a.b".
inline nlohmann::json& slot(nlohmann::json& j, const std::string& name) {
  const size_t dot = name.find('.');
  if (dot == std::string::npos) return j[name];
  return slot(j[name.substr(0, dot)], name.substr(dot + 1));
}
}  // namespace stat_detail

/// Writes every field S declares into `metrics`.
template <class S>
void put_stats(const S& s, nlohmann::json& metrics) {
  for_each_stat<S>([&](const auto& field) {
    const auto& value = s.*field.member;
    using T = std::decay_t<decltype(value)>;
    if constexpr (has_stat_fields<T>::value) {
      put_stats(value, metrics);
    } else if constexpr (is_stats_vector<T>::value) {
      using E = typename T::value_type;
      for_each_stat<E>([&](const auto& inner) {
        nlohmann::json column = nlohmann::json::array();
        for (const E& e : value) column.push_back(e.*inner.member);
        stat_detail::slot(metrics, inner.name) = std::move(column);
      });
    } else {
      stat_detail::slot(metrics, field.name) = value;
    }
  });
}

}  // namespace polyhex
