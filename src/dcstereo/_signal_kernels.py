"""Compiled kernel of ``signal.py``: the edge-padded matching signal in one pass.

The numpy path (``signal.matching_signal`` then ``np.pad``) makes several full-image
temporaries and runs on one core: on a Middlebury colour pair it took 2 ms, an eighth of
the whole ``dsi5`` match, and all of it serial. Here every padded row is computed straight
from its source row, rows in parallel, with the same float64 expressions in the same order,
so the values are those of the numpy path, bit for bit.

A ``uint8`` colour row reads its three weighted channels from tables of the 256 products
``v * LUMA[i]`` (the float64 products the expression makes, so the same sums): the
interleaved three-byte pixels leave the arithmetic loop scalar, and the tables halve its
time (a 434 x 383 colour image: 0.32 -> 0.16 ms). Rows of RGB (three channels, C order, at
least 8 pixels: every Middlebury image) run vector code instead, 8 pixels at a time, with
the same products and sums (``_rgb_pixels``): 0.21 -> 0.155 ms on that image, 1 thread.
"""

import numba as nb
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic, overload

#: ``mode`` of ``padded_signal``: how a stored value becomes the 0..255 intensity scale.
MODE_UINT8 = 0  # as is
MODE_UINT16 = 1  # / 257
MODE_FLOAT = 2  # * 255 (floats in [0, 1])

#: BT.601 luma weights of R, G and B (the weights the Middlebury tools use).
LUMA = (0.299, 0.587, 0.114)


@nb.njit(cache=True, inline="always")
def _pad_ends(out, yp, radius, width):
    """Repeat padded row ``yp``'s first and last image pixels over its ``radius`` ends."""
    for x in range(radius):
        out[yp, x] = out[yp, radius]
        out[yp, radius + width + x] = out[yp, radius + width - 1]


@nb.njit(cache=True, inline="always")
def _row(image, y, mul, div, colour, steps, out, yp, radius):
    """Write padded row ``yp`` of ``out`` from row ``y`` (a value's intensity: ``v * mul / div``).

    The callers pass constants (1 or the scale), so the compiler folds the identities away
    and each call is its own loop; ``x * 1.0`` and ``x / 1.0`` are exact, so the values are
    those of ``signal.intensity``'s single multiplication or division.
    """
    width = image.shape[1]
    for x in range(width):
        if colour:
            lum = (
                (np.float64(image[y, x, 0]) * mul / div) * LUMA[0]
                + (np.float64(image[y, x, 1]) * mul / div) * LUMA[1]
            ) + (np.float64(image[y, x, 2]) * mul / div) * LUMA[2]
        else:
            lum = np.float64(image[y, x, 0]) * mul / div
        out[yp, radius + x] = np.int32(np.rint(lum * steps))
    _pad_ends(out, yp, radius, width)


@nb.njit(cache=True, inline="always")
def _row_tables(image, y, tables, steps, out, yp, radius):
    """``_row`` of a ``uint8`` colour image, the channel products read from ``tables``.

    (Compiled for every dtype, ``padded_signal``'s branches being chosen at run time; the
    ``np.intp`` casts type it, and only ``uint8`` images run it.)
    """
    width = image.shape[1]
    for x in range(width):
        v0, v1, v2 = np.intp(image[y, x, 0]), np.intp(image[y, x, 1]), np.intp(image[y, x, 2])
        lum = (tables[0, v0] + tables[1, v1]) + tables[2, v2]
        out[yp, radius + x] = np.int32(np.rint(lum * steps))
    _pad_ends(out, yp, radius, width)


def _rgb_pixels(image, y, x0, steps, out, yp, o_out):
    """Write ``_LANES`` pixels ``x0..`` of a ``uint8`` RGB row to ``out[yp, o_out + ..]``.

    The values of ``_row_tables``: the products ``v * LUMA[i]`` (the tables hold exactly
    these float64 products), summed in the same order. ``image`` has three channels (the
    caller's test: the vector form takes a pixel as three bytes). Compiled code runs
    ``_rgb_pixels_vector`` for C-contiguous images.
    """
    for i in range(_LANES):
        x = x0 + i
        lum = (
            np.float64(image[y, x, 0]) * LUMA[0] + np.float64(image[y, x, 1]) * LUMA[1]
        ) + np.float64(image[y, x, 2]) * LUMA[2]
        out[yp, o_out + i] = np.int32(np.rint(lum * steps))


#: Pixels of one vector of ``_rgb_pixels`` (eight float64 values: two AVX2 registers).
_LANES = 8


# The three-byte pixels keep numba's loop vectorizer away (the tables' loads are gathers,
# the arithmetic form was scalar too). The vector form loads 8 pixels' 24 bytes at once,
# takes each channel's 8 bytes out by shuffles, and does the float64 arithmetic of the
# scalar expression on 8 lanes (plain fmul and fadd, which LLVM does not fuse; llvm.rint
# rounds half to even, as np.rint does).
@intrinsic
def _rgb_pixels_vector(typingctx, image, y, x0, steps, out, yp, o_out):
    if not (
        isinstance(image, types.Array)
        and image.dtype == types.uint8
        and image.ndim == 3
        and image.layout == "C"
        and isinstance(out, types.Array)
        and out.dtype == types.int32
        and out.ndim == 2
        and out.layout == "C"
        and all(isinstance(v, types.Integer) for v in (y, x0, steps, yp, o_out))
    ):
        return None
    i64 = ir.IntType(64)

    def codegen(context, builder, sig, args):
        y_v, x0_v, steps_v, yp_v, o_v = (
            context.cast(builder, args[i], sig.args[i], types.int64) for i in (1, 2, 3, 5, 6)
        )
        source = context.make_array(sig.args[0])(context, builder, args[0])
        target = context.make_array(sig.args[4])(context, builder, args[4])
        width = cgutils.unpack_tuple(builder, source.shape, 3)[1]
        width_out = cgutils.unpack_tuple(builder, target.shape, 2)[1]
        first = builder.mul(builder.add(builder.mul(y_v, width), x0_v), ir.Constant(i64, 3))
        bytes_type = ir.VectorType(ir.IntType(8), 3 * _LANES)
        pointer = builder.bitcast(builder.gep(source.data, [first]), bytes_type.as_pointer())
        packed = builder.load(pointer, align=1)
        f64x = ir.VectorType(ir.DoubleType(), _LANES)
        lanes = ir.VectorType(ir.IntType(32), _LANES)

        def channel(c, weight):
            picked = builder.shuffle_vector(
                packed,
                ir.Constant(bytes_type, ir.Undefined),
                ir.Constant(lanes, [3 * i + c for i in range(_LANES)]),
            )
            value = builder.uitofp(picked, f64x)
            return builder.fmul(value, ir.Constant(f64x, [weight] * _LANES))

        lum = builder.fadd(
            builder.fadd(channel(0, LUMA[0]), channel(1, LUMA[1])), channel(2, LUMA[2])
        )
        scale = builder.sitofp(steps_v, ir.DoubleType())
        undef = ir.Constant(f64x, ir.Undefined)
        scale_v = builder.shuffle_vector(
            builder.insert_element(undef, scale, ir.Constant(ir.IntType(32), 0)),
            undef,
            ir.Constant(lanes, [0] * _LANES),
        )
        rint = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(f64x, [f64x]), f"llvm.rint.v{_LANES}f64"
        )
        rounded = builder.call(rint, [builder.fmul(lum, scale_v)])
        values = builder.fptosi(rounded, lanes)
        at = builder.add(builder.mul(yp_v, width_out), o_v)
        target_pointer = builder.bitcast(builder.gep(target.data, [at]), lanes.as_pointer())
        builder.store(values, target_pointer, align=4)
        return context.get_dummy_value()

    return types.void(image, y, x0, steps, out, yp, o_out), codegen


@overload(_rgb_pixels)
def _rgb_pixels_compiled(image, y, x0, steps, out, yp, o_out):
    if not (isinstance(image, types.Array) and image.layout == "C" and image.dtype == types.uint8):
        return _rgb_pixels
    return lambda image, y, x0, steps, out, yp, o_out: _rgb_pixels_vector(
        image, y, x0, steps, out, yp, o_out
    )


@nb.njit(cache=True, inline="always")
def _row_rgb(image, y, steps, out, yp, radius):
    """``_row_tables`` of a three-channel image ``_LANES`` pixels at a time (at least that wide).

    A last block that would pass the row's end is taken ``_LANES`` pixels back from it: it
    writes some pixels twice, with the same values.
    """
    width = image.shape[1]
    for b in range((width + _LANES - 1) // _LANES):
        x0 = min(b * _LANES, width - _LANES)
        _rgb_pixels(image, y, x0, steps, out, yp, radius + x0)
    _pad_ends(out, yp, radius, width)


@nb.njit(cache=True, parallel=True)
def padded_signal(image, mode, steps, radius, out):
    """Write the matching signal of ``image`` (H, W, C), edge-padded by ``radius``, to ``out``.

    ``out`` is int32 ``(H + 2 radius, W + 2 radius)``; ``C`` is 1 (gray) or 3 / 4 (colour:
    BT.601 luma of the first three channels, alpha ignored). A value is
    ``rint(intensity * steps)``, the intensity as ``signal.intensity`` computes it.
    """
    height = image.shape[0]
    colour = image.shape[2] >= 3
    tables = np.empty((3, 256), dtype=np.float64)
    for v in range(256):
        for i in range(3):
            tables[i, v] = np.float64(v) * LUMA[i]
    for yp in nb.prange(height + 2 * radius):
        y = min(max(yp - radius, 0), height - 1)
        if colour:
            if mode == MODE_UINT8 and image.shape[2] == 3 and image.shape[1] >= _LANES:
                _row_rgb(image, y, steps, out, yp, radius)
            elif mode == MODE_UINT8:
                _row_tables(image, y, tables, steps, out, yp, radius)
            elif mode == MODE_UINT16:
                _row(image, y, 1.0, 257.0, True, steps, out, yp, radius)
            else:
                _row(image, y, 255.0, 1.0, True, steps, out, yp, radius)
        elif mode == MODE_UINT8:
            _row(image, y, 1.0, 1.0, False, steps, out, yp, radius)
        elif mode == MODE_UINT16:
            _row(image, y, 1.0, 257.0, False, steps, out, yp, radius)
        else:
            _row(image, y, 255.0, 1.0, False, steps, out, yp, radius)
