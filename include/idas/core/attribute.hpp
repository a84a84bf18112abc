// Typed attributes on simplices, stored struct-of-arrays and reached through handles.
//
// Every write an operation makes goes through that operation's journal (the old bytes
// are saved), named explicitly by the accessor it writes with, so a rollback restores
// each value exactly. Values must be trivially copyable: that is what lets the journal
// save and restore them with memcpy and lets the hot path avoid any per-type dispatch.
#pragma once

#include <idas/core/types.hpp>

#include <concepts>
#include <cstddef>
#include <cstring>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

namespace idas {

template <class T>
concept attribute_value = std::is_trivially_copyable_v<T> && std::is_default_constructible_v<T>;

/// Typed name of an attribute column. Cheap to copy; valid for the mesh that made it.
template <attribute_value T, simplex_kind Kind>
struct attribute_handle {
    std::uint32_t column = ~std::uint32_t{0};
    using value_type = T;
    static constexpr simplex_kind kind = Kind;
    bool valid() const noexcept { return column != ~std::uint32_t{0}; }
};

template <class T>
using vertex_attribute = attribute_handle<T, simplex_kind::vertex>;
template <class T>
using edge_attribute = attribute_handle<T, simplex_kind::edge>;
template <class T>
using face_attribute = attribute_handle<T, simplex_kind::face>;
template <class T>
using tet_attribute = attribute_handle<T, simplex_kind::tet>;

namespace detail {

/// Type-erased column. The raw pointer/stride fields serve the journal (rollback is a
/// memcpy, no dispatch); the virtual functions run only on growth, copy and compaction.
struct column_base {
    std::byte* data = nullptr;
    std::uint32_t stride = 0;
    std::size_t count = 0; // slots held; kept here so growth checks need no dispatch
    simplex_kind kind = simplex_kind::vertex;
    std::vector<std::byte> default_bytes; // lets new slots be reset with a memcpy
    std::string name;

    virtual ~column_base() = default;
    virtual void grow(std::size_t n) = 0; // size >= n, new slots default
    virtual std::unique_ptr<column_base> clone() const = 0;
    virtual void fill_default(std::size_t from, std::size_t to) = 0;
    /// Keeps slot old_of_new[i] as slot i (compaction after removals).
    virtual void remap(const std::vector<index_t>& old_of_new) = 0;
    virtual std::size_t size() const = 0;
};

template <attribute_value T>
struct column final : column_base {
    std::vector<T> values;
    T default_value{};

    column(std::string n, simplex_kind k, T dflt)
        : default_value(dflt) {
        name = std::move(n);
        kind = k;
        stride = sizeof(T);
        default_bytes.resize(sizeof(T));
        std::memcpy(default_bytes.data(), &default_value, sizeof(T));
        sync();
    }
    void sync() {
        data = reinterpret_cast<std::byte*>(values.data());
        count = values.size();
    }
    void grow(std::size_t n) override {
        if (values.size() >= n) return;
        // Geometric growth keeps resizes (and this virtual call) off the per-operation path.
        std::size_t cap = std::max<std::size_t>(n, values.size() + values.size() / 2 + 16);
        values.resize(cap, default_value);
        sync();
    }
    std::unique_ptr<column_base> clone() const override {
        auto c = std::make_unique<column<T>>(name, kind, default_value);
        c->values = values;
        c->sync();
        return c;
    }
    void fill_default(std::size_t from, std::size_t to) override {
        for (std::size_t i = from; i < to && i < values.size(); ++i) values[i] = default_value;
    }
    void remap(const std::vector<index_t>& old_of_new) override {
        std::vector<T> out(std::max<std::size_t>(old_of_new.size(), 1), default_value);
        for (std::size_t i = 0; i < old_of_new.size(); ++i) out[i] = values[old_of_new[i]];
        values = std::move(out);
        sync();
    }
    std::size_t size() const override { return values.size(); }
};

} // namespace detail

/// Per-thread undo log of attribute writes: (column, slot, old bytes).
class attribute_journal {
public:
    void save(std::uint32_t column, index_t slot, const std::byte* bytes, std::uint32_t size) {
        records_.push_back({column, slot, static_cast<std::uint32_t>(bytes_.size()), size});
        bytes_.insert(bytes_.end(), bytes, bytes + size);
    }
    std::size_t mark() const noexcept { return records_.size(); }
    /// Restores every value written since `mark`, newest first.
    void rollback(std::size_t mark, const std::vector<std::unique_ptr<detail::column_base>>& cols) {
        for (std::size_t i = records_.size(); i-- > mark;) {
            const record& r = records_[i];
            detail::column_base& c = *cols[r.column];
            std::memcpy(c.data + std::size_t(r.slot) * c.stride, bytes_.data() + r.offset, r.size);
        }
        truncate(mark);
    }
    void truncate(std::size_t mark) {
        if (mark < records_.size()) {
            bytes_.resize(records_[mark].offset);
            records_.resize(mark);
        }
    }
    void clear() noexcept { records_.clear(), bytes_.clear(); }
    bool empty() const noexcept { return records_.empty(); }

private:
    struct record {
        std::uint32_t column;
        index_t slot;
        std::uint32_t offset;
        std::uint32_t size;
    };
    std::vector<record> records_; // capacity is kept: no allocation in steady state
    std::vector<std::byte> bytes_;
};

/// What names the journal of a running operation: the `op_result` that `after` gets.
/// Writes inside an operation go through it, never through the thread.
template <class E>
concept names_journal = requires(const E& e) {
    { e.journal } -> std::convertible_to<attribute_journal*>;
};

namespace detail {
template <class>
inline constexpr bool unjournaled_write = false;
} // namespace detail

/// Read-only view of one attribute column: what a const mesh hands out, so hooks that see
/// the mesh before an operation (`before`, `priority`, invariants) cannot write.
template <attribute_value T>
class attribute_view {
public:
    explicit attribute_view(const detail::column<T>* c)
        : col_(c) {}
    const T& operator[](index_t i) const noexcept { return col_->values[i]; }
    const T& get(index_t i) const noexcept { return col_->values[i]; }

private:
    const detail::column<T>* col_;
};

/// Set-up access to one column, outside operations (`m.attribute(h)` on a non-const
/// mesh): reads, and unjournaled writes through `raw`. It has no `set`: a write inside an
/// operation must be undone if the operation is refused, so `after` writes through the
/// journaled accessor `m.attribute(h, r)` instead.
template <attribute_value T>
class attribute_setup {
public:
    explicit attribute_setup(detail::column<T>* c)
        : col_(c) {}

    const T& operator[](index_t i) const noexcept { return col_->values[i]; }
    const T& get(index_t i) const noexcept { return col_->values[i]; }

    /// Unjournaled mutable access, for set-up outside operations.
    T& raw(index_t i) noexcept { return col_->values[i]; }

    template <class U = T>
    void set(index_t, const U&) {
        static_assert(detail::unjournaled_write<U>,
                      "idas: m.attribute(h).set() / m.positions().set() would write without the "
                      "operation's journal, so a refused operation could not undo it: inside "
                      "`after`, write through m.attribute(h, r) / m.positions(r) (r: the "
                      "op_result); outside operations, use raw(i) = value");
    }
    template <class U = T>
    T& write(index_t i) {
        static_assert(detail::unjournaled_write<U>,
                      "idas: m.attribute(h).write() would write without the operation's "
                      "journal: inside `after`, use m.attribute(h, r).write(i); outside "
                      "operations, raw(i)");
        return col_->values[i];
    }

    operator attribute_view<T>() const noexcept { return attribute_view<T>(col_); }

private:
    detail::column<T>* col_;
};

/// Journaled access to one column for a running operation (`m.attribute(h, r)`): `set`
/// and `write` save the old value in that operation's journal first.
template <attribute_value T>
class attribute_accessor {
public:
    attribute_accessor(detail::column<T>* c, std::uint32_t id, attribute_journal& journal)
        : col_(c)
        , journal_(&journal)
        , id_(id) {}

    const T& operator[](index_t i) const noexcept { return col_->values[i]; }
    const T& get(index_t i) const noexcept { return col_->values[i]; }

    void set(index_t i, const T& v) { write(i) = v; }

    /// Journals the slot, then hands out a mutable reference to it.
    T& write(index_t i) {
        journal_->save(id_, i, reinterpret_cast<const std::byte*>(&col_->values[i]), sizeof(T));
        return col_->values[i];
    }

    operator attribute_view<T>() const noexcept { return attribute_view<T>(col_); }

private:
    detail::column<T>* col_;
    attribute_journal* journal_;
    std::uint32_t id_;
};

/// All attribute columns of one mesh.
class attribute_registry {
public:
    attribute_registry() = default;
    attribute_registry(const attribute_registry& o) { *this = o; }
    attribute_registry& operator=(const attribute_registry& o) {
        if (this == &o) return *this;
        columns_.clear();
        for (const auto& c : o.columns_) columns_.push_back(c ? c->clone() : nullptr);
        return *this;
    }
    attribute_registry(attribute_registry&&) noexcept = default;
    attribute_registry& operator=(attribute_registry&&) noexcept = default;

    template <attribute_value T, simplex_kind K>
    attribute_handle<T, K> add(std::string name, std::size_t slots, T dflt = T{}) {
        auto c = std::make_unique<detail::column<T>>(std::move(name), K, dflt);
        c->grow(slots);
        // A removed column's place is taken first, so adding and removing in a loop (an
        // algorithm's temporaries, run after run) does not grow the list.
        for (std::uint32_t i = 0; i < columns_.size(); ++i)
            if (!columns_[i]) {
                columns_[i] = std::move(c);
                return {i};
            }
        columns_.push_back(std::move(c));
        return {static_cast<std::uint32_t>(columns_.size() - 1)};
    }

    /// Removes a column; its handle (and copies of it) must not be used again.
    template <attribute_value T, simplex_kind K>
    void remove(attribute_handle<T, K> h) {
        if (h.column < columns_.size()) columns_[h.column].reset();
    }

    /// How many columns there are (positions included).
    std::size_t size() const noexcept {
        std::size_t n = 0;
        for (const auto& c : columns_) n += c != nullptr;
        return n;
    }

    template <attribute_value T, simplex_kind K>
    attribute_setup<T> setup(attribute_handle<T, K> h) {
        return attribute_setup<T>(static_cast<detail::column<T>*>(columns_[h.column].get()));
    }
    template <attribute_value T, simplex_kind K>
    attribute_accessor<T> access(attribute_handle<T, K> h, attribute_journal& journal) {
        return {static_cast<detail::column<T>*>(columns_[h.column].get()), h.column, journal};
    }
    template <attribute_value T, simplex_kind K>
    attribute_view<T> view(attribute_handle<T, K> h) const {
        return attribute_view<T>(static_cast<const detail::column<T>*>(columns_[h.column].get()));
    }

    /// Looks a column up by name (set-up code only; not for hot paths).
    template <attribute_value T, simplex_kind K>
    attribute_handle<T, K> find(const std::string& name) const {
        for (std::uint32_t i = 0; i < columns_.size(); ++i)
            if (columns_[i] && columns_[i]->name == name && columns_[i]->kind == K &&
                dynamic_cast<detail::column<T>*>(columns_[i].get()))
                return {i};
        return {};
    }

    /// Makes every column of `kind` hold at least `slots` values.
    void ensure(simplex_kind kind, std::size_t slots) {
        for (auto& c : columns_)
            if (c && c->kind == kind && c->count < slots) c->grow(slots);
    }
    /// Resets slot `i` of every column of `kind` to its default (a new simplex of the
    /// operation that owns `journal`).
    void reset_slot(simplex_kind kind, index_t i, attribute_journal& journal) {
        for (std::uint32_t k = 0; k < columns_.size(); ++k) {
            if (!columns_[k] || columns_[k]->kind != kind) continue;
            auto& c = *columns_[k];
            std::byte* slot = c.data + std::size_t(i) * c.stride;
            // A recycled slot still holds its old value; journal it so rollback is exact.
            journal.save(k, i, slot, c.stride);
            std::memcpy(slot, c.default_bytes.data(), c.stride);
        }
    }
    void remap(simplex_kind kind, const std::vector<index_t>& old_of_new) {
        for (auto& c : columns_)
            if (c && c->kind == kind) c->remap(old_of_new);
    }

    /// Every column slot; a removed column's is null.
    const std::vector<std::unique_ptr<detail::column_base>>& columns() const noexcept {
        return columns_;
    }

private:
    std::vector<std::unique_ptr<detail::column_base>> columns_;
};

} // namespace idas
