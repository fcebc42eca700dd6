#pragma once
// FLANN's headers trip the project's warnings: include them as a system header.
#pragma GCC system_header
#include <flann/flann.hpp>
