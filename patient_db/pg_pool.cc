#include "patient_db/pg_pool.h"

#include <stdexcept>
#include <utility>

namespace ves::patient_db {

PgPool::PgPool(std::string url, size_t max_size) : url_(std::move(url)), max_size_(max_size) {
  if (max_size_ == 0) throw std::invalid_argument("PostgreSQL pool size must be > 0, not 0");
}

std::unique_ptr<pqxx::connection> PgPool::Connect() const {
  auto conn = std::make_unique<pqxx::connection>(url_);
  // Records are durable when COMMIT returns, whatever the server's default.
  conn->set_variable("synchronous_commit", "on");
  return conn;
}

PgPool::Lease PgPool::Acquire() {
  std::unique_ptr<pqxx::connection> conn;
  {
    std::unique_lock lock(mutex_);
    ++waiting_;
    available_.wait(lock, [&] { return on_loan_ < max_size_; });
    --waiting_;
    ++on_loan_;
    if (!idle_.empty()) {
      conn = std::move(idle_.back());
      idle_.pop_back();
    }
  }
  if (!conn) {
    try {
      conn = Connect();
    } catch (...) {
      Return(nullptr);
      throw;
    }
  }
  return Lease(this, std::move(conn));
}

size_t PgPool::waiting() {
  std::lock_guard lock(mutex_);
  return waiting_;
}

void PgPool::Return(std::unique_ptr<pqxx::connection> conn) {
  {
    std::lock_guard lock(mutex_);
    --on_loan_;
    if (conn && conn->is_open()) idle_.push_back(std::move(conn));
  }
  available_.notify_one();
}

PgPool::Lease::~Lease() {
  if (pool_) pool_->Return(std::move(conn_));
}

}  // namespace ves::patient_db
