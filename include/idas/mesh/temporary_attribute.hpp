// An algorithm's own attribute column, removed when the algorithm returns (or throws), so
// a user's mesh comes back with the columns it went in with.
#pragma once

namespace idas {

template <class Mesh, class Handle>
class temporary_attribute {
public:
    temporary_attribute(Mesh& m, Handle h)
        : mesh_(m)
        , handle(h) {}
    temporary_attribute(const temporary_attribute&) = delete;
    temporary_attribute& operator=(const temporary_attribute&) = delete;
    ~temporary_attribute() { mesh_.remove_attribute(handle); }

private:
    Mesh& mesh_;

public:
    const Handle handle;
};

} // namespace idas
