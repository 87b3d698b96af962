!> Dense linear algebra of the core: LAPACK wrappers (symmetric
!> eigen-decomposition, Cholesky inverse with log-determinant), the
!> symmetric products' kernels, a pivoted Cholesky choosing independent
!> columns, the matrix exponential, and least squares by QR.
module mlid_linalg
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_SINGULAR, MLID_ERR_INTERNAL
  implicit none
  private
  public :: add_sym_atb, add_syrk, add_atv, sym_atb_t, pair_rows, sym_eig, chol_inverse, chol_solve, &
            psd_factor, info_inverse, info_eig, eig_inverse, expm, expm_into, expm_work_size, &
            expm_work_t, solve, independent_columns, general_eig, sym_sqrt_jacobi, &
            qr_least_squares, dot2

  interface
    subroutine dsyevr(jobz, range, uplo, n, a, lda, vl, vu, il, iu, abstol, m, w, z, ldz, &
                      isuppz, work, lwork, iwork, liwork, info)
      import :: wp
      character, intent(in) :: jobz, range, uplo
      integer, intent(in) :: n, lda, il, iu, ldz, lwork, liwork
      real(wp), intent(inout) :: a(lda, *)
      real(wp), intent(in) :: vl, vu, abstol
      integer, intent(out) :: m, info
      real(wp), intent(out) :: w(*), z(ldz, *), work(*)
      integer, intent(out) :: isuppz(*), iwork(*)
    end subroutine dsyevr
    subroutine dpotrf(uplo, n, a, lda, info)
      import :: wp
      character, intent(in) :: uplo
      integer, intent(in) :: n, lda
      real(wp), intent(inout) :: a(lda, *)
      integer, intent(out) :: info
    end subroutine dpotrf
    subroutine dpotri(uplo, n, a, lda, info)
      import :: wp
      character, intent(in) :: uplo
      integer, intent(in) :: n, lda
      real(wp), intent(inout) :: a(lda, *)
      integer, intent(out) :: info
    end subroutine dpotri
    subroutine dgesv(n, nrhs, a, lda, ipiv, b, ldb, info)
      import :: wp
      integer, intent(in) :: n, nrhs, lda, ldb
      real(wp), intent(inout) :: a(lda, *), b(ldb, *)
      integer, intent(out) :: ipiv(*), info
    end subroutine dgesv
    subroutine dgeev(jobvl, jobvr, n, a, lda, wr, wi, vl, ldvl, vr, ldvr, work, lwork, info)
      import :: wp
      character, intent(in) :: jobvl, jobvr
      integer, intent(in) :: n, lda, ldvl, ldvr, lwork
      real(wp), intent(inout) :: a(lda, *)
      real(wp), intent(out) :: wr(*), wi(*), vl(ldvl, *), vr(ldvr, *), work(*)
      integer, intent(out) :: info
    end subroutine dgeev
    subroutine dgeqrf(m, n, a, lda, tau, work, lwork, info)
      import :: wp
      integer, intent(in) :: m, n, lda, lwork
      real(wp), intent(inout) :: a(lda, *)
      real(wp), intent(out) :: tau(*), work(*)
      integer, intent(out) :: info
    end subroutine dgeqrf
    subroutine dormqr(side, trans, m, n, k, a, lda, tau, c, ldc, work, lwork, info)
      import :: wp
      character, intent(in) :: side, trans
      integer, intent(in) :: m, n, k, lda, ldc, lwork
      real(wp), intent(in) :: a(lda, *), tau(*)
      real(wp), intent(inout) :: c(ldc, *)
      real(wp), intent(out) :: work(*)
      integer, intent(out) :: info
    end subroutine dormqr
    subroutine dtrtrs(uplo, trans, diag, n, nrhs, a, lda, b, ldb, info)
      import :: wp
      character, intent(in) :: uplo, trans, diag
      integer, intent(in) :: n, nrhs, lda, ldb
      real(wp), intent(in) :: a(lda, *)
      real(wp), intent(inout) :: b(ldb, *)
      integer, intent(out) :: info
    end subroutine dtrtrs
    subroutine dtrtri(uplo, diag, n, a, lda, info)
      import :: wp
      character, intent(in) :: uplo, diag
      integer, intent(in) :: n, lda
      real(wp), intent(inout) :: a(lda, *)
      integer, intent(out) :: info
    end subroutine dtrtri
  end interface

  !> Below this size chol_inverse factorises without LAPACK.
  integer, parameter :: SMALL_N = 12
  !> Rows a pass of dot8_cols (a multiple of eight): seven columns'
  !> worth (28 kB) stays in the L1 cache for the four passes over them.
  integer, parameter :: DOT_ROWS = 512

  !> expm_into's work arrays (n x n, and the LU's pivots), kept by a caller
  !> that takes exponentials of one size over and over.
  type :: expm_work_t
    real(wp), allocatable :: x(:, :), n(:, :), d(:, :), as(:, :), t(:, :), colsum(:)
    integer, allocatable :: ipiv(:)
  end type expm_work_t

contains

  !> b = b + x' y where that is symmetric (x, y: m x n, as sequences: a
  !> sum over samples and outputs flattened): the upper triangle by dot
  !> products, mirrored; half the work of the full product.
  subroutine add_sym_atb(m, n, x, y, b)
    integer, intent(in) :: m, n
    real(wp), intent(in) :: x(m, n), y(m, n)
    real(wp), intent(inout) :: b(n, n)
    call sym_atb(m, m, n, x, y, b)
  end subroutine add_sym_atb

  !> c = c + w' w over the first m rows of w (m x n used), the symmetric
  !> rank-m update.  BLAS dsyrk does the same; the reference BLAS that Debian
  !> links by default takes three to seven times as long for n ~ 10 (its dot
  !> products are one dependent chain), and OpenBLAS takes about as long at
  !> that size.
  subroutine add_syrk(m, n, w, c)
    integer, intent(in) :: m, n
    real(wp), intent(in), contiguous :: w(:, :)
    real(wp), intent(inout) :: c(n, n)
    call sym_atb(m, size(w, 1), n, w, w, c)
  end subroutine add_syrk

  !> b = b + x(1:m, :)' y(1:m, :) where that is symmetric, x and y with
  !> leading dimension ld: the upper triangle by dot products (dot8's),
  !> mirrored (half the work of the full product); a row of the triangle
  !> six or three entries at a time (x(:, k) read once for them).
  subroutine sym_atb(m, ld, n, x, y, b)
    integer, intent(in) :: m, ld, n
    real(wp), intent(in) :: x(ld, n), y(ld, n)
    real(wp), intent(inout) :: b(n, n)
    real(wp) :: d(6)
    integer :: k, l, q
    do k = 1, n
      l = k
      do while (l + 5 <= n)
        call dot8_cols(6, m, ld, x(1, k), y(1, l), d)
        do q = 0, 5
          call add_entry(k, l + q, d(q + 1))
        end do
        l = l + 6
      end do
      if (l + 2 <= n) then
        call dot8_cols(3, m, ld, x(1, k), y(1, l), d)
        do q = 0, 2
          call add_entry(k, l + q, d(q + 1))
        end do
        l = l + 3
      end if
      do l = l, n
        call add_entry(k, l, dot8(m, x(:, k), y(:, l)))
      end do
    end do

  contains

    !> b(k, l) and its mirror b(l, k) plus d (k <= l).
    subroutine add_entry(k, l, d)
      integer, intent(in) :: k, l
      real(wp), intent(in) :: d
      b(k, l) = b(k, l) + d
      if (k < l) b(l, k) = b(l, k) + d
    end subroutine add_entry

  end subroutine sym_atb

  !> The rows a transposed operand of sym_atb_t needs for n columns: whole
  !> pairs (an odd n's padding row is read, its sums never reach b; the
  !> caller zeroes it so that it holds no NaN or infinity to trap on).
  pure integer function pair_rows(n)
    integer, intent(in) :: n
    pair_rows = 2*((n + 1)/2)
  end function pair_rows

  !> The upper triangle of b = b + xt(1:n, 1:m) yt(1:n, 1:m)' where that
  !> is symmetric (each entry k <= l the sum over the columns j of xt(k, j)
  !> yt(l, j), in order, then added to b; the lower triangle is left as it
  !> is: the caller reads the upper one).  xt and yt (ld >= pair_rows(n);
  !> an odd n's row n+1 read, not added to b) go by pairs of columns l0, l0+1 of b, each
  !> down to the diagonal in tiles of up to four pairs of rows (pairs):
  !> the triangle in blocks of 2 x 2, none below the diagonal's.
  subroutine sym_atb_t(m, ld, n, xt, yt, b)
    integer, intent(in) :: m, ld, n
    real(wp), intent(in) :: xt(ld, m), yt(ld, m)
    real(wp), intent(inout) :: b(n, n)
    real(wp) :: d(2, 8)
    integer :: k0, l0, np, p, k
    do l0 = 1, n, 2
      do k0 = 1, l0, 8
        np = min(4, (l0 - k0)/2 + 1)         ! pairs of rows, down to the diagonal's
        select case (np)                     ! a constant np each: pairs' clones
        case (1)
          call pairs(1, m, ld, xt(k0, 1), yt(l0, 1), d)
        case (2)
          call pairs(2, m, ld, xt(k0, 1), yt(l0, 1), d)
        case (3)
          call pairs(3, m, ld, xt(k0, 1), yt(l0, 1), d)
        case default
          call pairs(4, m, ld, xt(k0, 1), yt(l0, 1), d)
        end select
        do p = 1, np                         ! pair p's block: d(:, 2p-1) straight, d(:, 2p) swapped
          k = k0 + 2*p - 2
          b(k, l0) = b(k, l0) + d(1, 2*p - 1)
          if (k < l0) b(k + 1, l0) = b(k + 1, l0) + d(2, 2*p)     ! not below the diagonal
          if (l0 < n) then                   ! not the padding
            b(k, l0 + 1) = b(k, l0 + 1) + d(1, 2*p)
            b(k + 1, l0 + 1) = b(k + 1, l0 + 1) + d(2, 2*p - 1)
          end if
        end do
      end do
    end do
  end subroutine sym_atb_t

  !> For the pairs p = 1..np (np <= 4) of xt's rows 2p-1, 2p and yt's rows
  !> 1, 2, the sums over the m columns j, in order: d(:, 2p-1) of
  !> xt(2p-1:2p, j) yt(1:2, j), d(:, 2p) of xt(2p-1:2p, j) yt(2:1:-1, j)
  !> (the y pair swapped: one shuffle a column, then one vector product and
  !> sum for each half of the pair block, where one y value each would take
  !> two to broadcast).  Up to eight accumulators: independent chains that
  !> keep both adders busy.  np by value: each call's constant np makes a
  !> clone with the loop over p unrolled.  novector: gfortran 12's loop
  !> vectorizer, allowed at it, swaps each x pair too (five shuffles a
  !> sample, not one; the same sums either way).
  pure subroutine pairs(np, m, ld, xt, yt, d)
    integer, value :: np
    integer, intent(in) :: m, ld
    real(wp), intent(in) :: xt(ld, *), yt(ld, *)
    real(wp), intent(out) :: d(2, 8)
    real(wp) :: y(2), r(2)
    integer :: j, p
    d = 0.0_wp
    !GCC$ novector
    !GCC$ unroll 4
    do j = 1, m
      y = yt(1:2, j)
      r = y(2:1:-1)
      do concurrent (p = 1:np)
        d(:, 2*p - 1) = d(:, 2*p - 1) + xt(2*p - 1:2*p, j)*y
        d(:, 2*p) = d(:, 2*p) + xt(2*p - 1:2*p, j)*r
      end do
    end do
  end subroutine pairs

  !> g = g + w' v over the first m rows of w and v (as dgemv).
  subroutine add_atv(m, n, w, v, g)
    integer, intent(in) :: m, n
    real(wp), intent(in), contiguous :: w(:, :), v(:)
    real(wp), intent(inout) :: g(n)
    integer :: k
    do k = 1, n
      g(k) = g(k) + dot8(m, w(:, k), v)
    end do
  end subroutine add_atv

  !> x . y with eight partial sums: independent chains the processor
  !> pipelines and vectorizes (one running sum waits on each addition),
  !> added in a fixed order.
  pure real(wp) function dot8(m, x, y) result(d)
    integer, intent(in) :: m
    real(wp), intent(in) :: x(m), y(m)
    real(wp) :: s(8)
    integer :: i, m8
    s = 0.0_wp
    m8 = m - mod(m, 8)
    !GCC$ unroll 2
    do i = 1, m8, 8
      s = s + x(i:i + 7)*y(i:i + 7)
    end do
    d = dot8_total(s)
    do i = m8 + 1, m
      d = d + x(i)*y(i)
    end do
  end function dot8

  !> dot8 of x with nq (<= 6) columns y(:, 1:nq) at once: d(q) = x . y(:, q),
  !> each with dot8's eight partial sums (each in order), added in dot8's
  !> order.  The partial sums a pair at a time over DOT_ROWS rows (one
  !> vector register for each column), so a pair of x's values is read
  !> once for the nq products; the rows in blocks that stay in the L1
  !> cache for the four passes.  nq by value: each call's constant makes a
  !> clone.
  pure subroutine dot8_cols(nq, m, ld, x, y, d)
    integer, value :: nq
    integer, intent(in) :: m, ld
    real(wp), intent(in) :: x(m), y(ld, nq)
    real(wp), intent(out) :: d(nq)
    real(wp) :: s(8, 6), a(2, 6)
    integer :: i, i0, i1, m8, p, q
    s = 0.0_wp
    m8 = m - mod(m, 8)
    do i0 = 1, m8, DOT_ROWS
      i1 = min(m8, i0 + DOT_ROWS - 1)
      do p = 0, 6, 2                  ! partial sums p+1 and p+2
        a(:, 1:nq) = s(p + 1:p + 2, 1:nq)
        !GCC$ novector
        !GCC$ unroll 2
        do i = i0 + p, i1, 8
          do q = 1, nq
            a(:, q) = a(:, q) + x(i:i + 1)*y(i:i + 1, q)
          end do
        end do
        s(p + 1:p + 2, 1:nq) = a(:, 1:nq)
      end do
    end do
    do q = 1, nq
      d(q) = dot8_total(s(:, q))
      do i = m8 + 1, m
        d(q) = d(q) + x(i)*y(i, q)
      end do
    end do
  end subroutine dot8_cols

  !> dot8's eight partial sums added in its fixed order (the one place of
  !> that order: dot8 and dot8_cols agree to the bit through it).
  pure real(wp) function dot8_total(s)
    real(wp), intent(in) :: s(8)
    dot8_total = ((s(1) + s(5)) + (s(2) + s(6))) + ((s(3) + s(7)) + (s(4) + s(8)))
  end function dot8_total

  !> All eigenvalues (ascending) and eigenvectors of a symmetric matrix.
  !> info /= 0 reports a LAPACK failure.
  subroutine sym_eig(a, w, v, info)
    real(wp), intent(in) :: a(:, :)
    real(wp), intent(out) :: w(:)
    real(wp), intent(out) :: v(:, :)
    integer, intent(out) :: info
    real(wp), allocatable :: acopy(:, :), work(:)
    integer, allocatable :: iwork(:), isuppz(:)
    real(wp) :: wq(1)
    integer :: iwq(1), n, m

    n = size(a, 1)
    if (n == 0) then
      info = 0
      return
    end if
    acopy = a
    allocate (isuppz(2*n))
    call dsyevr('V', 'A', 'L', n, acopy, n, 0.0_wp, 0.0_wp, 0, 0, 0.0_wp, m, w, v, n, &
                isuppz, wq, -1, iwq, -1, info)
    if (info /= 0) return
    allocate (work(int(wq(1))), iwork(iwq(1)))
    call dsyevr('V', 'A', 'L', n, acopy, n, 0.0_wp, 0.0_wp, 0, 0, 0.0_wp, m, w, v, n, &
                isuppz, work, size(work), iwork, size(iwork), info)
  end subroutine sym_eig

  !> The symmetric square root s of a symmetric matrix A = V diag(w) V'
  !> (s = V diag(sqrt(max(w, 0))) V', negative eigenvalues taken as 0),
  !> from v, an orthogonal basis near A's eigenvectors (the identity when
  !> none is known; on exit the basis reached): B = V' A V is brought near
  !> diagonal by cyclic Jacobi rotations (near_diagonal), then sqrt(B) is
  !> solved for to rounding around its diagonal (sqrt_near_diagonal) and
  !> s = V sqrt(B) V'.  From the basis of a matrix close by (a filter's
  !> covariance a sample before) few rotations or none are needed, where
  !> a fresh decomposition (sym_eig, LAPACK's dsyevr) costs several times
  !> more at the filters' sizes (n ~ 10).  info = 1: no convergence.
  pure subroutine sym_sqrt_jacobi(a, v, s, info)
    real(wp), intent(in) :: a(:, :)
    real(wp), intent(inout) :: v(:, :)
    real(wp), intent(out) :: s(:, :)
    integer, intent(out) :: info
    call sqrt_jacobi(size(a, 1), a, v, s, info)
  end subroutine sym_sqrt_jacobi

  !> sym_sqrt_jacobi on explicit shapes (unit strides), the products by
  !> columns and the symmetric ones by their upper triangle: this runs at
  !> every sample of the UKF, where matmul's temporaries cost as much as
  !> the arithmetic.
  pure subroutine sqrt_jacobi(n, a, v, s, info)
    integer, intent(in) :: n
    real(wp), intent(in) :: a(n, n)
    real(wp), intent(inout) :: v(n, n)
    real(wp), intent(out) :: s(n, n)
    integer, intent(out) :: info
    real(wp) :: b(n, n), w(n, n), d(n)
    integer :: p, q
    call product_ab(n, a, v, w)                 ! w = A V, b = V' w
    do q = 1, n
      do p = 1, q
        b(p, q) = dot2(n, v(:, p), w(:, q))
        b(q, p) = b(p, q)
      end do
    end do
    call near_diagonal(n, b, v, d, info)
    if (info == 0) call sqrt_near_diagonal(n, b, d, w, info)
    if (info /= 0) then
      s = 0.0_wp
      return
    end if
    do q = 1, n                                 ! b = sqrt(B) V'
      b(:, q) = w(:, 1)*v(q, 1)
      do p = 2, n
        b(:, q) = b(:, q) + w(:, p)*v(q, p)
      end do
    end do
    do q = 1, n                                 ! s = V b, the upper triangle, mirrored
      s(1:q, q) = v(1:q, 1)*b(1, q)
      do p = 2, n
        s(1:q, q) = s(1:q, q) + v(1:q, p)*b(p, q)
      end do
      s(q, 1:q - 1) = s(1:q - 1, q)
    end do
  end subroutine sqrt_jacobi

  !> Cyclic Jacobi rotations of the symmetric b (and its basis v) while an
  !> off-diagonal entry exceeds tol (d_p + d_q) min(d_p, d_q), d =
  !> sqrt(max(diag b, 0)) (and eps max|diag b|: rounding), tol = 0.1/max(n, 10):
  !> then the first-order root's entries b_pq/(d_p + d_q) are below tol
  !> min(d_p, d_q), where sqrt_near_diagonal's iteration contracts by 2 n
  !> tol = 0.2 or less.  info = 1: no convergence in 40 sweeps.
  pure subroutine near_diagonal(n, b, v, d, info)
    integer, intent(in) :: n
    real(wp), intent(inout) :: b(n, n), v(n, n)
    real(wp), intent(out) :: d(n)
    integer, intent(out) :: info
    real(wp) :: tol, floor
    integer :: sweep, p, q
    logical :: rotated
    tol = 0.1_wp/max(n, 10)
    floor = 0.0_wp
    do q = 1, n
      d(q) = sqrt(max(b(q, q), 0.0_wp))
      floor = max(floor, abs(b(q, q)))
    end do
    floor = epsilon(tol)*floor
    info = 1
    do sweep = 1, 40
      rotated = .false.
      do q = 2, n
        do p = 1, q - 1
          if (abs(b(p, q)) <= max(tol*(d(p) + d(q))*min(d(p), d(q)), floor)) cycle
          call jacobi_rotate(n, b, v, p, q)
          d(p) = sqrt(max(b(p, p), 0.0_wp))
          d(q) = sqrt(max(b(q, q), 0.0_wp))
          rotated = .true.
        end do
      end do
      if (.not. rotated) then
        info = 0
        exit
      end if
    end do
  end subroutine near_diagonal

  !> x = sqrt(B) for a symmetric B near its diagonal d^2 (d = sqrt(max(diag
  !> B, 0))): x = D + Y with D Y + Y D = E - Y^2, E = B's off-diagonal part
  !> (an entry below rounding of the largest variance, eps max d^2, taken
  !> as 0: near_diagonal leaves those unrotated, and between two variances
  !> as small the iteration would not contract),
  !> solved entry by entry, Y_pq = (E - Y^2)_pq/(d_p + d_q), from the
  !> first-order root Y = E_pq/(d_p + d_q) until no entry moves by more
  !> than 4 eps (min(d_p, d_q) + eps max d): near_diagonal's tolerance makes
  !> the step contract by 0.2 or less, so the error left is below a
  !> quarter of the last move.  info = 1: not in 60 steps.
  pure subroutine sqrt_near_diagonal(n, b, d, x, info)
    integer, intent(in) :: n
    real(wp), intent(in) :: b(n, n), d(n)
    real(wp), intent(out) :: x(n, n)
    integer, intent(out) :: info
    real(wp) :: h(n, n), e(n, n), tl(n, n), y2(n, n), ynew, dmax, eps
    integer :: it, p, q
    logical :: moved
    eps = epsilon(1.0_wp)
    dmax = maxval(d)
    do q = 1, n                       ! the upper triangles: 1/(d_p + d_q), E, the tolerance
      do p = 1, q
        h(p, q) = 0.0_wp
        if (d(p) + d(q) > 0.0_wp) h(p, q) = 1.0_wp/(d(p) + d(q))
        e(p, q) = merge(b(p, q), 0.0_wp, p /= q .and. abs(b(p, q)) > eps*dmax*dmax)
        tl(p, q) = 4.0_wp*eps*(min(d(p), d(q)) + eps*dmax)
        x(p, q) = e(p, q)*h(p, q)      ! Y, until the end
        x(q, p) = x(p, q)
      end do
    end do
    info = 1
    do it = 1, 60
      do q = 1, n                     ! Y^2's upper triangle (Y symmetric)
        do p = 1, q
          y2(p, q) = dot2(n, x(:, p), x(:, q))
        end do
      end do
      moved = .false.
      do q = 1, n
        do p = 1, q
          ynew = (e(p, q) - y2(p, q))*h(p, q)
          moved = moved .or. abs(ynew - x(p, q)) > tl(p, q)
          x(p, q) = ynew
          x(q, p) = ynew
        end do
      end do
      if (.not. moved) then
        info = 0
        exit
      end if
    end do
    do q = 1, n
      x(q, q) = x(q, q) + d(q)
    end do
  end subroutine sqrt_near_diagonal

  !> x'y in two interleaved partial sums (odd and even terms): two
  !> independent chains of additions, which the compiler can pack.
  pure real(wp) function dot2(n, x, y) result(s)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(n), y(n)
    real(wp) :: s1, s2
    integer :: k
    s1 = 0.0_wp
    s2 = 0.0_wp
    do k = 1, n - 1, 2
      s1 = s1 + x(k)*y(k)
      s2 = s2 + x(k + 1)*y(k + 1)
    end do
    if (mod(n, 2) == 1) s1 = s1 + x(n)*y(n)
    s = s1 + s2
  end function dot2

  !> c = a b, all n x n, column by column.
  pure subroutine product_ab(n, a, b, c)
    integer, intent(in) :: n
    real(wp), intent(in) :: a(n, n), b(n, n)
    real(wp), intent(out) :: c(n, n)
    integer :: j, k
    do j = 1, n
      c(:, j) = a(:, 1)*b(1, j)
      do k = 2, n
        c(:, j) = c(:, j) + a(:, k)*b(k, j)
      end do
    end do
  end subroutine product_ab

  !> One Jacobi rotation zeroing b(p, q) (p /= q) of the symmetric b,
  !> b <- J' b J, v <- v J: columns p and q turned, then copied to the rows.
  pure subroutine jacobi_rotate(n, b, v, p, q)
    integer, intent(in) :: n, p, q
    real(wp), intent(inout) :: b(n, n), v(n, n)
    real(wp) :: theta, t, c, sn, bp, bq, app, aqq, apq
    integer :: r
    app = b(p, p)
    aqq = b(q, q)
    apq = b(p, q)
    theta = (aqq - app)/(2.0_wp*apq)
    t = sign(1.0_wp, theta)/(abs(theta) + sqrt(theta**2 + 1.0_wp))
    c = 1.0_wp/sqrt(t**2 + 1.0_wp)
    sn = t*c
    do r = 1, n
      bp = b(r, p)
      bq = b(r, q)
      b(r, p) = c*bp - sn*bq
      b(r, q) = sn*bp + c*bq
      bp = v(r, p)
      bq = v(r, q)
      v(r, p) = c*bp - sn*bq
      v(r, q) = sn*bp + c*bq
    end do
    b(p, :) = b(:, p)
    b(q, :) = b(:, q)
    b(p, p) = app - t*apq
    b(q, q) = aqq + t*apq
    b(p, q) = 0.0_wp
    b(q, p) = 0.0_wp
  end subroutine jacobi_rotate

  !> The eigenvalues wr + i wi of a general square matrix (no vectors).
  !> info /= 0 reports a LAPACK failure.
  subroutine general_eig(a, wr, wi, info)
    real(wp), intent(in) :: a(:, :)
    real(wp), intent(out) :: wr(:), wi(:)
    integer, intent(out) :: info
    real(wp) :: acopy(size(a, 1), size(a, 1)), vl(1, 1), vr(1, 1), work(8*size(a, 1) + 8)
    integer :: n
    n = size(a, 1)
    info = 0
    if (n == 0) return
    acopy = a
    call dgeev('N', 'N', n, acopy, n, wr, wi, vl, 1, vr, 1, work, size(work), info)
  end subroutine general_eig

  !> The same by a plain Cholesky factorisation for small n, where LAPACK's
  !> call overhead outweighs the arithmetic.  info = k > 0: the leading minor
  !> of order k is not positive definite.  n <= SMALL_N: the factors live in
  !> fixed-size locals, so that the filter's call at every sample allocates
  !> nothing.
  pure subroutine small_chol_inverse(a, ainv, logdet, info)
    real(wp), intent(in) :: a(:, :)
    real(wp), intent(out) :: ainv(:, :), logdet
    integer, intent(out) :: info
    real(wp) :: l(SMALL_N, SMALL_N), li(SMALL_N, SMALL_N), d
    integer :: n, i, j, k

    n = size(a, 1)
    info = 0
    logdet = 0.0_wp
    l(1:n, 1:n) = 0.0_wp
    do j = 1, n
      d = a(j, j) - sum(l(j, 1:j - 1)**2)
      if (.not. d > 0.0_wp) then
        info = j
        ainv = 0.0_wp
        return
      end if
      l(j, j) = sqrt(d)
      logdet = logdet + log(d)
      do i = j + 1, n
        l(i, j) = (a(i, j) - sum(l(i, 1:j - 1)*l(j, 1:j - 1)))/l(j, j)
      end do
    end do
    ! L^-1 by forward substitution, then A^-1 = L^-T L^-1
    li(1:n, 1:n) = 0.0_wp
    do k = 1, n
      li(k, k) = 1.0_wp/l(k, k)
      do i = k + 1, n
        li(i, k) = -sum(l(i, k:i - 1)*li(k:i - 1, k))/l(i, i)
      end do
    end do
    do j = 1, n
      do i = j, n
        ainv(i, j) = sum(li(i:n, i)*li(i:n, j))
        ainv(j, i) = ainv(i, j)
      end do
    end do
  end subroutine small_chol_inverse

  !> x = A^-1 b for a symmetric positive-definite A by a plain Cholesky
  !> factorisation and two substitutions: for the small systems solved
  !> many times over (the frequency domain's transient terms), where
  !> forming the inverse through LAPACK costs several times more.  info =
  !> k > 0: the leading minor of order k is not positive definite.
  pure subroutine chol_solve(a, b, x, info)
    real(wp), intent(in) :: a(:, :), b(:)
    real(wp), intent(out) :: x(:)
    integer, intent(out) :: info
    real(wp) :: l(size(a, 1), size(a, 1)), d
    integer :: n, i, j

    n = size(a, 1)
    info = 0
    x = 0.0_wp
    do j = 1, n
      d = a(j, j) - sum(l(j, 1:j - 1)**2)
      if (.not. d > 0.0_wp) then
        info = j
        return
      end if
      l(j, j) = sqrt(d)
      do i = j + 1, n
        l(i, j) = (a(i, j) - sum(l(i, 1:j - 1)*l(j, 1:j - 1)))/l(j, j)
      end do
    end do
    do i = 1, n                    ! L z = b
      x(i) = (b(i) - sum(l(i, 1:i - 1)*x(1:i - 1)))/l(i, i)
    end do
    do i = n, 1, -1                ! L' x = z
      x(i) = (x(i) - sum(l(i + 1:n, i)*x(i + 1:n)))/l(i, i)
    end do
  end subroutine chol_solve

  !> The columns of a symmetric positive semi-definite A that a pivoted
  !> Cholesky factorisation of its unit-diagonal scaling keeps: each next
  !> the one farthest from the span of those kept, while its squared
  !> distance from it (relative to its own length) exceeds tol.  keep:
  !> their indices, ascending; zero columns are never kept.  O(n^2 k) for
  !> k kept, where an eigen-decomposition choosing a basis costs O(n^3)
  !> several times over.
  pure subroutine independent_columns(a, tol, keep)
    real(wp), intent(in) :: a(:, :), tol
    integer, allocatable, intent(out) :: keep(:)
    real(wp) :: l(size(a, 1), size(a, 1)), d(size(a, 1)), sc(size(a, 1))
    logical :: taken(size(a, 1))
    integer :: n, k, j, i

    n = size(a, 1)
    do i = 1, n
      sc(i) = 0.0_wp
      if (a(i, i) > 0.0_wp) sc(i) = 1.0_wp/sqrt(a(i, i))
    end do
    d = merge(1.0_wp, 0.0_wp, sc > 0.0_wp)   ! the Schur complement's diagonal
    taken = .false.
    do k = 1, n
      j = maxloc(d, 1, mask=.not. taken)
      if (.not. d(j) > tol) exit
      taken(j) = .true.
      do i = 1, n
        l(i, k) = (sc(i)*a(i, j)*sc(j) - sum(l(i, 1:k - 1)*l(j, 1:k - 1)))/sqrt(d(j))
      end do
      d = d - l(:, k)**2
      if (all(taken)) exit
    end do
    keep = pack([(i, i=1, n)], taken)
  end subroutine independent_columns

  !> Inverse and log-determinant of a symmetric positive-definite matrix.
  !> info > 0 means the matrix is not positive definite.
  subroutine chol_inverse(a, ainv, logdet, info)
    real(wp), intent(in) :: a(:, :)
    real(wp), intent(out) :: ainv(:, :)
    real(wp), intent(out) :: logdet
    integer, intent(out) :: info
    integer :: n, i, j

    n = size(a, 1)
    ainv = a
    logdet = 0.0_wp
    info = 0
    if (n == 0) return          ! LAPACK wants lda >= 1
    if (n <= SMALL_N) then      ! the filter's innovation covariance, every sample
      call small_chol_inverse(a, ainv, logdet, info)
      return
    end if
    call dpotrf('L', n, ainv, n, info)
    if (info /= 0) return
    do i = 1, n
      logdet = logdet + 2.0_wp*log(ainv(i, i))
    end do
    call dpotri('L', n, ainv, n, info)
    if (info /= 0) return
    do j = 1, n
      do i = 1, j - 1
        ainv(i, j) = ainv(j, i)
      end do
    end do
  end subroutine chol_inverse

  !> Lower-triangular L with L L' = A for a symmetric positive
  !> semi-definite A (zero pivots give zero columns), so that a diagonal A
  !> gives L = diag(sqrt(a_ii)).  ok is false when A is not semi-definite.
  subroutine psd_factor(a, l, ok)
    real(wp), intent(in) :: a(:, :)
    real(wp), intent(out) :: l(:, :)
    logical, intent(out) :: ok
    real(wp) :: d, tol
    integer :: n, i, j

    n = size(a, 1)
    l = 0.0_wp
    ok = .true.
    do j = 1, n
      ! a pivot is zero against its own diagonal entry, not the largest
      ! entry: a variable a million times smaller than another keeps its factor
      tol = 1.0e-12_wp*max(tiny(1.0_wp), abs(a(j, j)))
      d = a(j, j) - sum(l(j, 1:j - 1)**2)
      if (d < -tol) then
        ok = .false.
        return
      end if
      if (d <= tol) then
        ! a zero pivot: the rest of the column must vanish too
        do i = j + 1, n
          if (abs(a(i, j) - sum(l(i, 1:j - 1)*l(j, 1:j - 1))) > sqrt(tol)*sqrt(max(tol, a(i, i)))) then
            ok = .false.
            return
          end if
        end do
        cycle
      end if
      l(j, j) = sqrt(d)
      do i = j + 1, n
        l(i, j) = (a(i, j) - sum(l(i, 1:j - 1)*l(j, 1:j - 1)))/l(j, j)
      end do
    end do
  end subroutine psd_factor

  !> Eigen-decomposition of the normalised information matrix
  !> N = D^-1/2 M D^-1/2, D = diag(M) (report §5.3.5): the scale sc = D^-1/2
  !> (0 for a parameter with no information at all), eigenvalues w ascending
  !> and eigenvectors v.  Working on N keeps the parameters' units out of
  !> every singularity test and rank choice.  With unit present the
  !> parameters are measured in those units instead (sc = unit): the
  !> rank-deficient search uses the a priori magnitudes, so that a dropped
  !> direction is one not determined to within the parameters' own size.
  subroutine info_eig(info, sc, w, v, status, msg, unit)
    real(wp), intent(in) :: info(:, :)
    real(wp), intent(out) :: sc(:), w(:), v(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(in), optional :: unit(:)
    integer :: n, ierr

    status = MLID_OK
    msg = ''
    n = size(w)
    w = 0.0_wp
    v = 0.0_wp
    sc = 0.0_wp
    if (n == 0) return
    if (.not. all(ieee_is_finite(info))) then
      status = MLID_ERR_SINGULAR
      msg = 'information matrix is not finite'
      return
    end if
    if (present(unit)) then
      sc = unit
    else
      where (info_diag(info) > 0.0_wp) sc = 1.0_wp/sqrt(info_diag(info))
    end if
    call sym_eig(diag_scaled(info, sc), w, v, ierr)
    if (ierr /= 0) then
      status = MLID_ERR_INTERNAL
      write (msg, '(a,i0)') 'eigen-decomposition of the information matrix failed, dsyevr info = ', ierr
    end if
  end subroutine info_eig

  !> Inverse of the information matrix from info_eig keeping the rank
  !> largest eigenvalues of N (all above rcond times the largest when rank
  !> is absent): cov = D^-1/2 V_r L_r^-1 V_r' D^-1/2.  ndrop counts the
  !> eigenvalues left out below rcond; bad is the free parameter with the
  !> largest weight in the weakest direction.  w and vec return N's
  !> eigenvalues and eigenvectors.
  subroutine info_inverse(info, rcond, cov, w, ndrop, bad, status, msg, rank, vec)
    real(wp), intent(in) :: info(:, :)
    real(wp), intent(in) :: rcond
    real(wp), intent(out) :: cov(:, :), w(:)
    integer, intent(out) :: ndrop, bad, status
    character(len=*), intent(out) :: msg
    integer, intent(in), optional :: rank
    real(wp), intent(out), optional :: vec(:, :)   !< eigenvectors of the normalised matrix
    real(wp) :: v(size(w), size(w)), sc(size(w))

    call info_eig(info, sc, w, v, status, msg)
    if (present(vec)) vec = v
    ndrop = 0
    bad = 0
    cov = 0.0_wp
    if (status /= MLID_OK) return
    if (present(rank)) then
      call eig_inverse(sc, w, v, rcond, rank, cov, ndrop, bad)
    else
      call eig_inverse(sc, w, v, rcond, size(w), cov, ndrop, bad)
    end if
  end subroutine info_inverse

  !> The inverse from info_eig's scale, eigenvalues and eigenvectors,
  !> keeping the rank largest eigenvalues (and only those above rcond times
  !> the largest): cov = D^-1/2 V_r L_r^-1 V_r' D^-1/2.  ndrop counts those
  !> below rcond; bad is the parameter with the largest weight in the
  !> weakest direction when any is dropped.
  pure subroutine eig_inverse(sc, w, v, rcond, rank, cov, ndrop, bad)
    real(wp), intent(in) :: sc(:), w(:), v(:, :), rcond
    integer, intent(in) :: rank
    real(wp), intent(out) :: cov(:, :)
    integer, intent(out) :: ndrop, bad
    real(wp) :: vw(size(w))
    integer :: n, k, j

    n = size(w)
    ndrop = 0
    bad = 0
    cov = 0.0_wp
    if (n == 0) return
    do k = 1, n
      if (w(k) > rcond*w(n) .and. w(n) > 0.0_wp) then
        if (k > n - rank) then       ! cov += v_k (v_k / w_k)', column by column
          vw = v(:, k)/w(k)
          do j = 1, n
            cov(:, j) = cov(:, j) + v(:, k)*vw(j)
          end do
        end if
      else
        ndrop = ndrop + 1
      end if
    end do
    cov = diag_scaled(cov, sc)
    if (ndrop > 0) bad = maxloc(abs(v(:, 1)), 1)
  end subroutine eig_inverse

  !> a(i, j) sc(j) sc(i), in that order: a symmetric scaling D a D,
  !> D = diag(sc), column by column (no spread temporaries).
  pure function diag_scaled(a, sc) result(b)
    real(wp), intent(in) :: a(:, :), sc(:)
    real(wp) :: b(size(a, 1), size(a, 2))
    integer :: j
    do j = 1, size(a, 2)
      b(:, j) = a(:, j)*sc(j)*sc
    end do
  end function diag_scaled

  !> x = A^-1 b for a general square A (LU, LAPACK dgesv); info > 0: singular.
  subroutine solve(a, b, x, info)
    real(wp), intent(in) :: a(:, :), b(:, :)
    real(wp), intent(out) :: x(:, :)
    integer, intent(out) :: info
    real(wp) :: lu(size(a, 1), size(a, 1))
    integer :: ipiv(size(a, 1)), n
    n = size(a, 1)
    x = b
    info = 0
    if (n == 0) return
    lu = a
    call dgesv(n, size(b, 2), lu, n, ipiv, x, n, info)
  end subroutine solve

  !> Matrix exponential e^A: diagonal Pade approximant of degree 6 after
  !> scaling A by 2^-s so that its norm is below 1/2, then s squarings
  !> (Moler & Van Loan's method 3); accurate to rounding for the norms here.
  subroutine expm(a, e, info)
    real(wp), intent(in) :: a(:, :)
    real(wp), intent(out) :: e(:, :)
    integer, intent(out) :: info
    type(expm_work_t) :: w
    call expm_work_size(w, size(a, 1))
    call expm_into(a, e, info, w)
  end subroutine expm

  !> Size expm_into's work arrays for n x n matrices (kept when they have it).
  subroutine expm_work_size(w, n)
    type(expm_work_t), intent(inout) :: w
    integer, intent(in) :: n
    if (allocated(w%x)) then
      if (size(w%x, 1) == n) return
      deallocate (w%x, w%n, w%d, w%as, w%t, w%colsum, w%ipiv)
    end if
    allocate (w%x(n, n), w%n(n, n), w%d(n, n), w%as(n, n), w%t(n, n), w%colsum(n), w%ipiv(n))
  end subroutine expm_work_size

  !> expm with the caller's work arrays w (expm_work_size): for exponentials
  !> taken at every sample, which then allocate nothing.
  subroutine expm_into(a, e, info, w)
    real(wp), intent(in) :: a(:, :)
    real(wp), intent(out) :: e(:, :)
    integer, intent(out) :: info
    type(expm_work_t), intent(inout) :: w
    integer, parameter :: q = 6
    real(wp) :: c, anorm
    integer :: k, sq, i, m

    info = 0
    m = size(a, 1)
    do i = 1, m
      w%colsum(i) = sum(abs(a(:, i)))
    end do
    anorm = maxval(w%colsum)
    if (.not. ieee_is_finite(anorm)) then
      info = -1
      e = 0.0_wp
      return
    end if
    associate (x => w%x, n => w%n, d => w%d, as => w%as, t => w%t)
      sq = max(0, exponent(anorm) + 1)
      as(:, :) = a/2.0_wp**sq
      x(:, :) = as
      c = 0.5_wp
      n(:, :) = c*as
      d(:, :) = -c*as
      do i = 1, m
        n(i, i) = n(i, i) + 1.0_wp
        d(i, i) = d(i, i) + 1.0_wp
      end do
      do k = 2, q
        c = c*real(q - k + 1, wp)/real(k*(2*q - k + 1), wp)
        t(:, :) = matmul(as, x)
        x(:, :) = t
        n(:, :) = n + c*x
        if (mod(k, 2) == 0) then
          d(:, :) = d + c*x
        else
          d(:, :) = d - c*x
        end if
      end do
      e = n                        ! solve's steps: D^-1 N by LU, D overwritten
      if (m == 0) return
      call dgesv(m, m, d, m, w%ipiv, e, m, info)
      if (info /= 0) return
      do k = 1, sq
        t(:, :) = matmul(e, e)
        e = t
      end do
    end associate
  end subroutine expm_into

  pure function info_diag(a) result(d)
    real(wp), intent(in) :: a(:, :)
    real(wp) :: d(size(a, 1))
    integer :: k
    do k = 1, size(d)
      d(k) = a(k, k)
    end do
  end function info_diag

  !> Least squares min |x theta - y| (x: n x p, n >= p) by Householder QR
  !> (LAPACK dgeqrf, dormqr, dtrtrs), and cdiag = diag((x'x)^-1) from R^-1
  !> (dtrtri): (x'x)^-1 = R^-1 R^-T.  info /= 0: LAPACK failed, or R is
  !> singular (info > 0: its zero diagonal entry), or out of memory (-1000).
  subroutine qr_least_squares(x, y, theta, cdiag, info)
    real(wp), intent(in) :: x(:, :), y(:)
    real(wp), intent(out) :: theta(:), cdiag(:)
    integer, intent(out) :: info
    real(wp), allocatable :: a(:, :), b(:, :), tau(:), work(:)
    real(wp) :: wq(1)
    integer :: n, p, i, ierr
    n = size(x, 1)
    p = size(x, 2)
    theta = 0.0_wp
    cdiag = 0.0_wp
    allocate (a(n, p), b(n, 1), tau(max(p, 1)), stat=ierr)
    if (ierr /= 0) then
      info = -1000
      return
    end if
    a = x
    b(:, 1) = y
    call dgeqrf(n, p, a, n, tau, wq, -1, info)
    if (info /= 0) return
    allocate (work(max(int(wq(1)), p, 1)), stat=ierr)
    if (ierr /= 0) then
      info = -1000
      return
    end if
    call dgeqrf(n, p, a, n, tau, work, size(work), info)
    if (info == 0) call dormqr('L', 'T', n, 1, p, a, n, tau, b, n, work, size(work), info)
    if (info == 0) call dtrtrs('U', 'N', 'N', p, 1, a, n, b, n, info)
    if (info /= 0) return
    theta = b(1:p, 1)
    call dtrtri('U', 'N', p, a, n, info)
    if (info /= 0) return
    do i = 1, p
      cdiag(i) = sum(a(i, i:p)**2)
    end do
  end subroutine qr_least_squares

end module mlid_linalg
