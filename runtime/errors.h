/// @file errors.h
/// @brief The error types of polyhex. Messages read "who: what, where".
///
/// - InvalidInput: the data given to a stage is unusable (bad mesh, self-intersecting surface).
/// - IOError: a file cannot be read or written, or its content is malformed (names the file).
/// - SolverError: a linear solve or factorization failed.
/// - ConfigError: a config or command line is wrong (names the node and the valid choices).
/// - Interrupted: the run was stopped by SIGINT/SIGTERM (runtime/cancel.h).
/// - NodeError: any error raised inside a node, wrapped by the runtime with the node id and type.
#pragma once

#include <stdexcept>
#include <string>

namespace polyhex {

struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};
struct InvalidInput : Error {
  using Error::Error;
};
struct IOError : Error {
  using Error::Error;
};
struct SolverError : Error {
  using Error::Error;
};
struct ConfigError : Error {
  using Error::Error;
};
struct Interrupted : Error {
  using Error::Error;
};
/// Raised by the runtime when a node body throws; what() is "node `id` (`type`): <message>".
struct NodeError : Error {
  NodeError(std::string id, std::string type, const std::string& message)
      : Error("node `" + id + "` (`" + type + "`): " + message), node_id(std::move(id)), node_type(std::move(type)) {}
  std::string node_id;
  std::string node_type;
};

}  // namespace polyhex
