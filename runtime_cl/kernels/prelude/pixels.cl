// The pixel types of the spreadlet kernels (splat.cl, gather.cl, rotate.cl), one definition.
// Build options: OC (output channels), DC (database channels), each 1 or 3, and CC (colour
// channels) 1, 3 or 4; OC = max(CC, DC). One channel is a float; three are a float4 (the 4th lane
// 0), so RGB moves as one vector; four (radiance and opacity of a depth layer) fill the 4th lane,
// which a 3-channel database spreads with its green PSF (LANE3).
//   pix_t          an output pixel
//   DB_VALUE(v, j) entry j of a database value array v as a pixel (1 channel: broadcast)
//   COLOUR(c, i)   pixel i of the colour input as a pixel (1 channel: grey)
//   IS_ZERO(v)     all lanes of a pixel are 0
//   TO_PIX(v)      a float4 accumulator as a pixel

#if OC == 1
typedef float pix_t;
#define DB_VALUE(v, j) ((v)[(j)])
#define COLOUR(c, i) ((c)[(i)])
#define IS_ZERO(v) ((v) == 0.0f)
#define TO_PIX(v) ((v).x)
#else
typedef float4 pix_t;
#if OC == 4
#define LANE3(v, j) ((v)[3 * (j) + 1])  // a 3-channel value array's green entry, for the 4th lane
#else
#define LANE3(v, j) 0.0f
#endif
#define IS_ZERO(v) all((v) == (float4)0.0f)  // vector compares give -1 per true lane
#define TO_PIX(v) (v)
#if DC == 1
#define DB_VALUE(v, j) ((float4)((v)[(j)]))
#else
#define DB_VALUE(v, j) ((float4)((v)[3 * (j)], (v)[3 * (j) + 1], (v)[3 * (j) + 2], LANE3(v, j)))
#endif
#if CC == 1
#define COLOUR(c, i) ((float4)((c)[(i)], (c)[(i)], (c)[(i)], 0.0f))
#elif CC == 3
#define COLOUR(c, i) ((float4)((c)[3 * (i)], (c)[3 * (i) + 1], (c)[3 * (i) + 2], 0.0f))
#else
#define COLOUR(c, i) vload4((i), (c))
#endif
#endif
