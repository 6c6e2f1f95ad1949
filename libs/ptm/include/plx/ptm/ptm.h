#pragma once
// Progressive texture maps (Marvie & Bouatouch section 4): codec and file format.

#include <plx/ptm/decoder.h>
#include <plx/ptm/encoder.h>
#include <plx/ptm/format.h>
#include <plx/ptm/mip.h>
