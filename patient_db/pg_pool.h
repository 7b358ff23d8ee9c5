#pragma once

#include <condition_variable>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <pqxx/connection>

// A bounded pool of libpqxx connections to one PostgreSQL database. Every
// connection has synchronous_commit=on (set with set_variable, which libpqxx
// restores if it ever reconnects), so a COMMIT returns only once its WAL is
// flushed. A connection that broke is dropped on return, not reused.
namespace ves::patient_db {

class PgPool {
 public:
  // Throws std::invalid_argument for size 0. Connects lazily.
  PgPool(std::string url, size_t max_size);
  PgPool(const PgPool&) = delete;
  PgPool& operator=(const PgPool&) = delete;

  // A connection on loan, handed back when it goes out of scope.
  class Lease {
   public:
    Lease(PgPool* pool, std::unique_ptr<pqxx::connection> conn)
        : pool_(pool), conn_(std::move(conn)) {}
    Lease(Lease&& other) noexcept : pool_(other.pool_), conn_(std::move(other.conn_)) {
      other.pool_ = nullptr;
    }
    Lease& operator=(Lease&&) = delete;
    ~Lease();
    pqxx::connection& conn() { return *conn_; }
    // Closes the connection so it is not reused (after a lost connection).
    void Discard() { conn_.reset(); }

   private:
    PgPool* pool_;
    std::unique_ptr<pqxx::connection> conn_;
  };

  // Waits while max_size connections are on loan; opens a new connection when
  // none is idle. Throws pqxx::broken_connection when it cannot connect.
  Lease Acquire();

  // Opens a connection outside the pool (migrations, in-doubt checks).
  std::unique_ptr<pqxx::connection> Connect() const;

  size_t max_size() const { return max_size_; }
  // Callers blocked in Acquire now (all max_size connections on loan).
  size_t waiting();

 private:
  void Return(std::unique_ptr<pqxx::connection> conn);

  const std::string url_;
  const size_t max_size_;
  std::mutex mutex_;
  std::condition_variable available_;
  std::vector<std::unique_ptr<pqxx::connection>> idle_;  // guarded by mutex_
  size_t on_loan_ = 0;                                    // guarded by mutex_
  size_t waiting_ = 0;                                    // guarded by mutex_
};

}  // namespace ves::patient_db
