!> A model whose evaluation of everything at once disagrees with its parts
!> by slip in df/dx (a model that shares a quantity wrongly): what
!> check_jacobians must catch.  xdot = p x + u, y = x.
module split_model
  use mlid_kinds, only: wp
  use mlid_models, only: model_t
  implicit none
  private
  public :: split_model_t

  type, extends(model_t) :: split_model_t
    real(wp) :: slip = 0.0_wp
  contains
    procedure :: eval => split_eval
    procedure :: dfdw => split_dfdw
    procedure :: dhdxp => split_dhdxp
  end type split_model_t

contains

  pure subroutine split_eval(self, t, x, u, p, idx, xdot, a, b, y, c, d)
    class(split_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(self%nx), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out), optional :: xdot(self%nx), a(self%nx, self%nx), b(self%nx, size(idx)), &
                                       y(self%ny), c(self%ny, self%nx), d(self%ny, size(idx))
    if (present(xdot)) xdot = p(1)*x + u(1)
    if (present(a)) a = p(1)
    if (present(a) .and. present(y)) a = p(1) + self%slip       ! wrong only all at once
    if (present(b)) b(:, 1:size(idx)) = spread(x, 2, size(idx))
    if (present(y)) y = x
    if (present(c)) c = 1.0_wp
    if (present(d)) d = 0.0_wp
  end subroutine split_eval

  pure subroutine split_dfdw(self, t, x, u, p, g)
    class(split_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: g(:, :)
    g = 0.0_wp
  end subroutine split_dfdw

  pure subroutine split_dhdxp(self, t, x, u, p, idx, dc)
    class(split_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: dc(:, :, :)
    dc = 0.0_wp
  end subroutine split_dhdxp

end module split_model

!> Unit tests of the core numerics: RK4 order and exactness, sensitivities
!> against finite differences, LAPACK wrappers, the random stream.
program test_numerics
  use mlid_kinds, only: wp, MLID_OK
  use mlid_models, only: model_t, model_layout, layout_t
  use mlid_model_factory, only: model_create, MODEL_LINEAR, MODEL_AERO_LONG, MODEL_EQUATIONS
  use mlid_equations, only: equations_text_codes
  use mlid_params, only: param_map_t, param_map_create, no_ties
  use mlid_jacobian_check, only: check_jacobians
  use mlid_options, only: options_t
  use mlid_filter, only: oe_predict
  use mlid_linalg, only: sym_eig, chol_inverse, chol_solve, independent_columns, add_sym_atb, psd_factor, &
                         sym_atb_t, pair_rows, sym_sqrt_jacobi
  use mlid_random, only: rng_t, rng_seed, rng_normal
  use mlid_text, only: itoa
  use test_checks, only: check, finish
  use split_model, only: split_model_t
  use mlid_rk, only: small_product, product_7x4_add, product_7x4_add_tail
  use mlid_colored, only: colored_bracket, BRACKET_FOURIER, BRACKET_DIRECT, BRACKET_AUTO
  use mlid_fft, only: fft_plan_t, fft_plan, fft_forward, fft_many, fft_real_many, fft_smooth_length, &
                      fft_real_pair
  implicit none

  call test_rk4_order()
  call test_sensitivities()
  call test_aero_jacobians()
  call test_aero_parameter_layouts()
  call test_split_evaluation()
  call test_folded_manoeuvres()
  call test_infinite_partial_unused()
  call test_linalg()
  call test_random()
  call test_small_product()
  call test_sym_products()
  call test_sym_order()
  call test_fft()
  call test_independent_columns()
  call test_sym_sqrt_jacobi()
  call test_colored_paths()
  call finish()

contains

  !> independent_columns on the gram of columns of very different sizes
  !> with two exact dependencies and a zero column: it keeps as many as the
  !> rank, never the zero one, and the kept columns span every column (the
  !> least-squares residual of each on them within rounding of its size);
  !> independent columns are all kept.
  !> The symmetric square root by Jacobi rotations (the UKF's sigma
  !> points): s s = A and s symmetric for a covariance whose eigenvalues
  !> span 1e-8 to 10, from the identity and warm from the basis of a matrix
  !> close by; equal to sym_eig's V diag(sqrt w) V'; a negative eigenvalue
  !> taken as 0.
  subroutine test_sym_sqrt_jacobi()
    type(rng_t) :: r
    real(wp) :: b(10, 10), a(10, 10), v(10, 10), s(10, 10), w(10), ve(10, 10), ref(10, 10)
    integer :: j, info, info2
    call rng_seed(r, 17)
    do j = 1, 10
      b(:, j) = normals(r, 10)*10.0_wp**(-0.4_wp*j)
    end do
    a = matmul(b, transpose(b))
    v = 0.0_wp
    do j = 1, 10
      v(j, j) = 1.0_wp
    end do
    call sym_sqrt_jacobi(a, v, s, info)
    call sym_eig(a, w, ve, info2)
    ref = matmul(ve*spread(sqrt(max(w, 0.0_wp)), 1, 10), transpose(ve))
    call check(info == 0 .and. info2 == 0, 'sym_sqrt_jacobi converges')
    call check(maxval(abs(matmul(s, s) - a)) < 1.0e-13_wp*maxval(abs(a)), &
               'sym_sqrt_jacobi: s s = A')
    call check(maxval(abs(s - transpose(s))) < 1.0e-14_wp*maxval(abs(s)) .and. &
               maxval(abs(s - ref)) < 1.0e-12_wp*maxval(abs(ref)), &
               'sym_sqrt_jacobi: symmetric, sym_eig''s square root')
    a(3, 3) = a(3, 3)*(1.0_wp + 1.0e-3_wp)        ! close by: warm from the basis reached
    call sym_sqrt_jacobi(a, v, s, info)
    call check(info == 0 .and. maxval(abs(matmul(s, s) - a)) < 1.0e-13_wp*maxval(abs(a)), &
               'sym_sqrt_jacobi from a nearby basis')
    w = [4.0_wp, -1.0_wp, 1.0_wp, 2.0_wp, 0.5_wp, 3.0_wp, 1.5_wp, 2.5_wp, 0.7_wp, 0.2_wp]
    a = matmul(ve*spread(w, 1, 10), transpose(ve))   ! sym_eig's basis, one eigenvalue < 0
    ref = matmul(ve*spread(sqrt(max(w, 0.0_wp)), 1, 10), transpose(ve))
    v = 0.0_wp
    do j = 1, 10
      v(j, j) = 1.0_wp
    end do
    call sym_sqrt_jacobi(a, v, s, info)
    call check(info == 0 .and. maxval(abs(s - ref)) < 1.0e-13_wp, &
               'sym_sqrt_jacobi takes negative eigenvalues as 0')
    ! two tiny variances, correlated below rounding of the largest: still a root
    a = 0.0_wp
    a(1, 1) = 100.0_wp
    a(2, 2) = 1.0e-16_wp
    a(3, 3) = 1.0e-16_wp
    a(2, 3) = 0.9e-16_wp
    a(3, 2) = 0.9e-16_wp
    do j = 4, 10
      a(j, j) = 1.0_wp
    end do
    v = 0.0_wp
    do j = 1, 10
      v(j, j) = 1.0_wp
    end do
    call sym_sqrt_jacobi(a, v, s, info)
    call check(info == 0 .and. all(s == s) .and. &
               maxval(abs(matmul(s, s) - a)) < 1.0e-13_wp*maxval(abs(a)), &
               'sym_sqrt_jacobi: tiny correlated variances beside a large one')
  end subroutine test_sym_sqrt_jacobi

  subroutine test_independent_columns()
    type(rng_t) :: r
    real(wp) :: b(40, 7), a(7, 7), x(7), res(40), worst
    integer, allocatable :: keep(:)
    integer :: j, info
    call rng_seed(r, 11)
    do j = 1, 7
      b(:, j) = normals(r, 40)*10.0_wp**(j - 4)
    end do
    b(:, 5) = 3.0e2_wp*b(:, 1) - b(:, 3)
    b(:, 6) = 0.0_wp
    b(:, 7) = b(:, 2) + 1.0e-3_wp*b(:, 4)
    a = matmul(transpose(b), b)
    call independent_columns(a, 1.0e-12_wp, keep)
    call check(size(keep) == 4, 'independent_columns keeps the rank''s number of columns')
    call check(all(keep /= 6), 'independent_columns never keeps a zero column')
    worst = 0.0_wp
    do j = 1, 7
      call chol_solve(a(keep, keep), a(keep, j), x(1:size(keep)), info)
      res = b(:, j) - matmul(b(:, keep), x(1:size(keep)))
      worst = max(worst, norm2(res)/max(norm2(b(:, j)), tiny(1.0_wp)))
    end do
    call check(info == 0 .and. worst < 1.0e-8_wp, 'the kept columns span every column')
    b(:, 5) = b(:, 5) + 1.0e-2_wp*normals(r, 40)
    b(:, 6) = normals(r, 40)
    b(:, 7) = normals(r, 40)
    call independent_columns(matmul(transpose(b), b), 1.0e-12_wp, keep)
    call check(size(keep) == 7, 'independent_columns keeps independent columns all')
  end subroutine test_independent_columns

  function normals(r, n) result(z)
    type(rng_t), intent(inout) :: r
    integer, intent(in) :: n
    real(wp) :: z(n)
    integer :: i
    do i = 1, n
      z(i) = rng_normal(r)
    end do
  end function normals

  !> fft_forward against the sum that defines the transform, at lengths
  !> whose stages take every radix (4, 2, 3, 5; powers of two with an odd
  !> and an even number of factors 2, 3 and 5 alone and mixed): within
  !> rounding of the sum's size.
  subroutine test_fft()
    type(rng_t) :: r
    type(fft_plan_t) :: plan
    complex(wp), allocatable :: z(:), e(:)
    real(wp) :: scale
    integer, parameter :: lengths(12) = [2, 8, 64, 128, 3, 6, 10, 25, 30, 90, 120, 250]
    integer :: n, k, i
    call rng_seed(r, 5)
    do i = 1, size(lengths)
      n = lengths(i)
      plan = fft_plan(n)
      allocate (z(0:n - 1))
      do k = 0, n - 1
        z(k) = cmplx(rng_normal(r), rng_normal(r), wp)
      end do
      e = dft(z)
      scale = sum(abs(z))
      call fft_forward(plan, z)
      call check(maxval(abs(z - e)) < 1.0e-13_wp*scale, 'fft_forward is the discrete Fourier transform')
      deallocate (z, e)
    end do
    call test_fft_many(r)
    call test_fft_real_many(r)
    call test_fft_real_pair(r)
    call check(fft_smooth_length(601 + 60) == 720 .and. fft_smooth_length(1) == 2 .and. &
               fft_smooth_length(1652) == 1728 .and. fft_smooth_length(15) == 16, &
               'fft_smooth_length: the next even 2^a 3^b 5^c')
  end subroutine test_fft

  !> The transform by its defining sum.
  function dft(z) result(e)
    complex(wp), intent(in) :: z(0:)
    complex(wp) :: e(0:size(z) - 1)
    real(wp), parameter :: two_pi = 8.0_wp*atan(1.0_wp)
    integer :: n, k, f
    n = size(z)
    do f = 0, n - 1
      e(f) = sum([(z(k)*exp(cmplx(0.0_wp, -two_pi*mod(f*k, n)/n, wp)), k=0, n - 1)])
    end do
  end function dft

  !> fft_many on 5 series at once (length 60: radices 4, 3, 5): each row the
  !> defining sum of its series, and the same to the bit as that series alone.
  subroutine test_fft_many(r)
    type(rng_t), intent(inout) :: r
    integer, parameter :: m = 5, n = 60
    type(fft_plan_t) :: plan
    real(wp) :: zr(m, 0:n - 1), zi(m, 0:n - 1), xr(1, 0:n - 1), xi(1, 0:n - 1)
    complex(wp) :: z0(m, 0:n - 1)
    real(wp) :: err
    integer :: j, k
    do k = 0, n - 1
      do j = 1, m
        z0(j, k) = cmplx(rng_normal(r), rng_normal(r), wp)
      end do
    end do
    zr = real(z0, wp)
    zi = aimag(z0)
    xr(1, :) = zr(3, :)
    xi(1, :) = zi(3, :)
    plan = fft_plan(n)
    call fft_many(plan, m, zr, zi)
    call fft_many(plan, 1, xr, xi)
    err = 0.0_wp
    do j = 1, m
      err = max(err, maxval(abs(cmplx(zr(j, :), zi(j, :), wp) - dft(z0(j, :))))/sum(abs(z0(j, :))))
    end do
    call check(err < 1.0e-13_wp, 'fft_many: each series its discrete Fourier transform')
    call check(all(xr(1, :) == zr(3, :)) .and. all(xi(1, :) == zi(3, :)), &
               'fft_many: a series alone is the same to the bit as one of many')
  end subroutine test_fft_many

  !> fft_real_many on 19 real series of 45 samples zero-padded to 60 (two
  !> blocks, the second with an odd count), sizes from 1e-6 to 1e6 (series
  !> that share a transform differ by up to 1e12): frequencies 0 .. 30 of
  !> each against the defining sum of the padded series, within rounding of
  !> the series' own size.
  subroutine test_fft_real_many(r)
    type(rng_t), intent(inout) :: r
    integer, parameter :: nr = 19, nt = 45, n = 60
    type(fft_plan_t) :: plan
    real(wp) :: x(nr, nt), fr(0:n/2, nr), fi(0:n/2, nr), err
    complex(wp) :: e(0:n - 1)
    integer :: j, k
    logical :: ok
    do k = 1, nt
      do j = 1, nr
        x(j, k) = rng_normal(r)*10.0_wp**merge(6, -6, j <= 8 .or. j > 16)   ! pairs j, j + 8
      end do
    end do
    plan = fft_plan(n)
    call fft_real_many(plan, x, fr, fi, ok)
    call check(ok, 'fft_real_many: its workspace allocated')
    err = 0.0_wp
    do j = 1, nr
      e = dft([cmplx(x(j, :), 0.0_wp, wp), (cmplx(0.0_wp, 0.0_wp, wp), k=nt, n - 1)])
      err = max(err, maxval(abs(cmplx(fr(:, j), fi(:, j), wp) - e(0:n/2)))/sum(abs(x(j, :))))
    end do
    call check(err < 1.0e-13_wp, 'fft_real_many: each row its transform, f = 0 .. n/2')
  end subroutine test_fft_real_many

  !> fft_real_pair (the frequency responses' transforms) against the sum that
  !> defines the transform: two series 1e12 apart in size, 50 samples
  !> zero-padded to 64, each within rounding of its own size.
  subroutine test_fft_real_pair(r)
    type(rng_t), intent(inout) :: r
    integer, parameter :: nt = 50, n = 64
    type(fft_plan_t) :: plan
    real(wp) :: x(nt), y(nt)
    complex(wp) :: xf(0:n/2), yf(0:n/2), ex(0:n - 1), ey(0:n - 1)
    integer :: k
    logical :: ok
    do k = 1, nt
      x(k) = 1.0e6_wp*rng_normal(r)
      y(k) = 1.0e-6_wp*rng_normal(r)
    end do
    plan = fft_plan(n)
    call fft_real_pair(plan, x, y, xf, yf, ok)
    call check(ok, 'fft_real_pair: its workspace allocated')
    ex = dft([cmplx(x, 0.0_wp, wp), (cmplx(0.0_wp, 0.0_wp, wp), k=nt, n - 1)])
    ey = dft([cmplx(y, 0.0_wp, wp), (cmplx(0.0_wp, 0.0_wp, wp), k=nt, n - 1)])
    call check(maxval(abs(xf - ex(0:n/2))) < 1.0e-13_wp*sum(abs(x)) .and. &
               maxval(abs(yf - ey(0:n/2))) < 1.0e-13_wp*sum(abs(y)), &
               'fft_real_pair: each series its transform, f = 0 .. n/2')
  end subroutine test_fft_real_pair

  !> The coloured-residual bracket sum_i sum_j a(i)' w(|i-j|) Rvv(i-j) a(j)
  !> (mlid_colored) by the transform, by the direct filter and as the core
  !> chooses, against that double sum written out: three segments (14, 1
  !> and 25 samples: transforms of 18 and 30 points, radices 2, 3 and 5),
  !> lags 0, 3 and 24, a random kernel (not symmetric at lags > 0), one
  !> parameter's sensitivities 1e-7 times the others': each entry within
  !> rounding of its own parameters' sizes, |a_k| |a_l| sum |Rvv|.  Outputs
  !> 1 to 7: the kernel product's passes for an odd and an even number of
  !> kernel columns, two rows a pass and a row alone.
  subroutine test_colored_paths()
    integer :: ny
    do ny = 1, 7
      call colored_paths(ny)
    end do
  end subroutine test_colored_paths

  subroutine colored_paths(ny)
    integer, intent(in) :: ny
    integer, parameter :: nt = 40, nf = 4, seg(3) = [1, 15, 16]
    integer, parameter :: lags(3) = [0, 3, 24]
    type(rng_t) :: r
    real(wp) :: a(ny, nt, nf), want(nf, nf), got(nf, nf), tol(nf, nf), na(nf)
    real(wp), allocatable :: rvv(:, :, :)
    integer :: i, j, k, l, c, s, hows(3), h, lag, ends(3)
    hows = [BRACKET_FOURIER, BRACKET_DIRECT, BRACKET_AUTO]
    ends = [14, 15, 40]
    call rng_seed(r, 23 + ny)
    do l = 1, nf
      do i = 1, nt
        do j = 1, ny
          a(j, i, l) = rng_normal(r)
        end do
      end do
    end do
    a(:, :, 2) = 1.0e-7_wp*a(:, :, 2)
    na = [(sqrt(sum(a(:, :, l)**2)), l=1, nf)]
    do c = 1, size(lags)
      lag = lags(c)
      allocate (rvv(ny, ny, 0:lag))
      do k = 0, lag
        do i = 1, ny
          do j = 1, ny
            rvv(j, i, k) = rng_normal(r)/(1 + k)
          end do
        end do
      end do
      rvv(:, :, 0) = 0.5_wp*(rvv(:, :, 0) + transpose(rvv(:, :, 0)))
      want = 0.0_wp
      do s = 1, size(seg)
        do i = seg(s), ends(s)
          do j = seg(s), ends(s)
            k = abs(i - j)
            if (k > lag) cycle
            if (i >= j) then                  ! Rvv(i - j), Rvv(-k) = Rvv(k)'
              want = want + (1 - real(k, wp)/(lag + 1))* &
                     matmul(transpose(a(:, i, :)), matmul(rvv(:, :, k), a(:, j, :)))
            else
              want = want + (1 - real(k, wp)/(lag + 1))* &
                     matmul(transpose(a(:, i, :)), matmul(transpose(rvv(:, :, k)), a(:, j, :)))
            end if
          end do
        end do
      end do
      tol = 1.0e-13_wp*sum(abs(rvv))*spread(na, 1, nf)*spread(na, 2, nf)
      do h = 1, size(hows)
        got = colored_bracket(a, rvv, seg, hows(h))
        call check(all(abs(got - want) < tol), &
                   'colored_bracket (transform, filter, chosen) is the double sum')
      end do
      deallocate (rvv)
    end do
  end subroutine colored_paths

  !> add_sym_atb (dot products) and sym_atb_t (transposed operands, tiles of
  !> one to four pairs of rows by a pair of columns) against the sums
  !> written out, for every column count 1..13 (odd ones with the padding
  !> row, each size of the tiles at the diagonal and above it) and row count
  !> 1..9 (the kernels' loops unrolled by four: each remainder): within
  !> rounding (4 eps sum |x||y|: they add the terms in another order), both
  !> triangles (sym_atb_t: the upper one, the lower left as it was), and
  !> what b held before kept.  The product's upper triangle is taken,
  !> mirrored, whether or not x' y is symmetric: so y may be any matrix here.
  subroutine test_sym_products()
    type(rng_t) :: r
    real(wp) :: x(9, 13), y(9, 13), q(13, 13), b(13, 13), e(13, 13), g(13, 13), w(9, 13)
    real(wp), allocatable :: wt(:, :)
    integer :: i, j, m, n
    logical :: ok_dot, ok_tiles
    call rng_seed(r, 17)
    do j = 1, 13
      do i = 1, 13
        q(i, j) = rng_normal(r)
      end do
      do i = 1, 9
        x(i, j) = rng_normal(r)
        w(i, j) = rng_normal(r)
      end do
    end do
    do n = 1, 13
      if (allocated(wt)) deallocate (wt)
      allocate (wt(pair_rows(n), size(w, 1)))
      ok_dot = .true.
      ok_tiles = .true.
      do m = 1, 9
        y = w                   ! x' y need not be symmetric: the upper triangle's, mirrored
        b = q
        call add_sym_atb(m, n, x(1:m, 1:n), y(1:m, 1:n), b(1:n, 1:n))
        call sym_expected(m, n, q, x, y, e, g)
        ok_dot = ok_dot .and. all(abs(b(1:n, 1:n) - e(1:n, 1:n)) <= 4*epsilon(1.0_wp)*g(1:n, 1:n))
        b = q                   ! the transposed operands, zero to the tiles' edge
        wt = 0.0_wp
        wt(1:n, 1:m) = transpose(w(1:m, 1:n))
        call sym_atb_t(m, pair_rows(n), n, wt, wt, b(1:n, 1:n))
        call sym_expected(m, n, q, w, w, e, g)
        do j = 1, n               ! its upper triangle only; below it b as it was
          ok_tiles = ok_tiles .and. all(abs(b(1:j, j) - e(1:j, j)) <= 4*epsilon(1.0_wp)*g(1:j, j)) &
                     .and. all(b(j + 1:n, j) == q(j + 1:n, j))
        end do
      end do
      call check(ok_dot, 'add_sym_atb is b + x''y (upper triangle, mirrored), n = '//itoa(n)//', m = 1..9')
      call check(ok_tiles, 'sym_atb_t is b + w''w over the first m rows, the upper triangle, n = '// &
                 itoa(n)//', m = 1..9')
    end do
  end subroutine test_sym_products

  !> add_sym_atb (a row of the triangle six or three dot products at a
  !> time) to the bit against each entry's dot product in dot8's order
  !> written out (eight partial sums by row mod 8, each in order; added
  !> ((1+5)+(2+6))+((3+7)+(4+8)); then the remainder rows in order), for
  !> every column count 1..13 (each mix of six, three and single columns)
  !> and row counts with and without a remainder, one to several rounds of
  !> eight, one and several passes of the kernels' rows (DOT_ROWS, 512).
  subroutine test_sym_order()
    integer, parameter :: ms(9) = [1, 7, 8, 9, 23, 40, 61, 512, 1109]
    type(rng_t) :: r
    real(wp) :: x(1109, 13), y(1109, 13), q(13, 13), b(13, 13), e(13, 13), s(8), d
    integer :: i, j, k, l, m, n, c
    logical :: ok
    call rng_seed(r, 19)
    do j = 1, 13
      do i = 1, 13
        q(i, j) = rng_normal(r)
      end do
      do i = 1, size(x, 1)
        x(i, j) = rng_normal(r)
        y(i, j) = rng_normal(r)
      end do
    end do
    do n = 1, 13
      ok = .true.
      do c = 1, size(ms)
        m = ms(c)
        b = q
        call add_sym_atb(m, n, x(1:m, 1:n), y(1:m, 1:n), b(1:n, 1:n))
        e = q
        do l = 1, n
          do k = 1, l
            s = 0.0_wp
            do i = 1, m - mod(m, 8)
              s(mod(i - 1, 8) + 1) = s(mod(i - 1, 8) + 1) + x(i, k)*y(i, l)
            end do
            d = ((s(1) + s(5)) + (s(2) + s(6))) + ((s(3) + s(7)) + (s(4) + s(8)))
            do i = m - mod(m, 8) + 1, m
              d = d + x(i, k)*y(i, l)
            end do
            e(k, l) = e(k, l) + d
            if (k < l) e(l, k) = e(l, k) + d
          end do
        end do
        ok = ok .and. all(b(1:n, 1:n) == e(1:n, 1:n))
      end do
      call check(ok, 'add_sym_atb is dot8''s sums to the bit, n = '//itoa(n))
    end do
  end subroutine test_sym_order

  !> e = q + x' y over the first m rows for k <= l, mirrored (the triangle
  !> the symmetric products compute), and g the sums of the terms' magnitudes.
  subroutine sym_expected(m, n, q, x, y, e, g)
    integer, intent(in) :: m, n
    real(wp), intent(in) :: q(:, :), x(:, :), y(:, :)
    real(wp), intent(out) :: e(:, :), g(:, :)
    integer :: k, l
    do l = 1, n
      do k = 1, l
        e(k, l) = q(k, l) + sum(x(1:m, k)*y(1:m, l))
        g(k, l) = abs(q(k, l)) + sum(abs(x(1:m, k)*y(1:m, l)))
        e(l, k) = q(l, k) + sum(x(1:m, k)*y(1:m, l))
        g(l, k) = abs(q(l, k)) + sum(abs(x(1:m, k)*y(1:m, l)))
      end do
    end do
  end subroutine sym_expected

  !> small_product, its fixed-size 4 x 4, 7 x 4 and 7 x 7 kernels and its
  !> general loops, against the sums written out: within rounding (4 eps
  !> sum |a||b|, as a native build may fuse multiply-adds differently; the
  !> portable build's sums are the same to the bit, which
  !> benchmarks/compare_cases.py checks on every deck).
  subroutine test_small_product()
    type(rng_t) :: r
    real(wp) :: a(7, 7), b(7, 11), c(7, 11), e(7, 11), g(7, 11)
    integer :: i, j, k, n, m
    call rng_seed(r, 11)
    do j = 1, size(a, 2)
      do i = 1, size(a, 1)
        a(i, j) = rng_normal(r)
      end do
    end do
    do j = 1, size(b, 2)
      do i = 1, size(b, 1)
        b(i, j) = rng_normal(r)
      end do
    end do
    do m = 3, 7              ! m = 4: the kernels of whole blocks of four
      do n = 4, 7, 3         ! n = m = 4, n = 7 and m = 4 or 7: the fixed-size kernels
        call small_product(a(1:n, 1:m), b(1:m, :), c(1:n, :))
        do j = 1, size(b, 2)
          do i = 1, n
            e(i, j) = a(i, 1)*b(1, j)
            g(i, j) = abs(a(i, 1)*b(1, j))
            do k = 2, m
              e(i, j) = e(i, j) + a(i, k)*b(k, j)
              g(i, j) = g(i, j) + abs(a(i, k)*b(k, j))
            end do
          end do
        end do
        call check(all(abs(c(1:n, :) - e(1:n, :)) <= 4*epsilon(1.0_wp)*g(1:n, :)), &
                   'small_product is the product a b')
      end do
    end do
    call test_product_add(a(:, 1:4), b(1:4, :))
  end subroutine test_small_product

  !> product_7x4_add (C S + dh/dp in one pass) is to the bit small_product
  !> followed by the first nd columns' w(k) d(:, k) added, for nd = 0 (no
  !> model parameter free), some and every column; with d's first four rows
  !> zero, product_7x4_add_tail the same.
  subroutine test_product_add(a, b)
    real(wp), intent(in) :: a(7, 4), b(4, 11)
    type(rng_t) :: r
    real(wp) :: d(7, 11), d4(7, 11), w(11), c(7, 11), e(7, 11)
    integer, parameter :: nds(3) = [0, 5, 11]
    integer :: i, k, q, nd
    call rng_seed(r, 12)
    do k = 1, 11
      w(k) = rng_normal(r)
      do i = 1, 7
        d(i, k) = rng_normal(r)
      end do
    end do
    do q = 1, size(nds)
      nd = nds(q)
      call product_7x4_add(11, nd, a, b, d(:, 1:nd), w(1:nd), c)
      call small_product(a, b, e)
      do k = 1, nd
        e(:, k) = e(:, k) + w(k)*d(:, k)
      end do
      call check(all(c == e), 'product_7x4_add is small_product + w d to the bit, nd = '//itoa(nd))
      d4 = d
      d4(1:4, :) = 0.0_wp
      call product_7x4_add(11, nd, a, b, d4(:, 1:nd), w(1:nd), e)
      call product_7x4_add_tail(11, nd, a, b, d4(:, 1:nd), w(1:nd), c)
      call check(all(c == e), 'product_7x4_add_tail (rows 5 to 7 alone where d''s first four '// &
                 'are zero) is product_7x4_add to the bit, nd = '//itoa(nd))
    end do
  end subroutine test_product_add

  !> xdot = a x + b u with u = t (linear between samples is exact for a
  !> ramp): RK4 error must fall 16x when dt halves.
  subroutine test_rk4_order()
    class(model_t), allocatable :: m
    type(options_t) :: opt
    type(param_map_t) :: pm
    real(wp) :: theta(13), e(2), a, b, tt, exact
    real(wp), allocatable :: t(:), u(:, :), y(:, :)
    integer :: status, k, n, j
    character(len=256) :: msg

    call model_create(MODEL_LINEAR, 1, 1, 1, 0, [integer ::], [real(wp) ::], m, status, msg)
    call param_map_create(model_layout(m), [0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0], no_ties(13), &
                          pm, status, msg)
    a = -2.0_wp
    b = 3.0_wp
    ! F G H D K bx x0 bias r delay udelay stab p0
    theta = [a, b, 1.0_wp, 0.0_wp, 0.0_wp, 0.0_wp, 1.0_wp, 0.0_wp, 1.0_wp, 0.0_wp, 0.0_wp, 0.0_wp, &
             0.0_wp]
    do k = 1, 2
      n = 10*2**k
      allocate (t(n + 1), u(1, n + 1), y(1, n + 1))
      t = [(real(j, wp)/n, j=0, n)]
      u(1, :) = t
      call oe_predict(m, theta, pm, t, u, opt, y, status, msg)
      tt = 1.0_wp
      ! x = x0 e^{at} - b t/a + b (e^{at} - 1)/a^2
      exact = exp(a*tt) - b*tt/a + b*(exp(a*tt) - 1.0_wp)/a**2
      e(k) = abs(y(1, n + 1) - exact)
      deallocate (t, u, y)
    end do
    call check(e(1)/e(2) > 12.0_wp .and. e(1)/e(2) < 20.0_wp, 'RK4 error ratio ~16 when dt halves')
    call check(e(2) < 1.0e-6_wp, 'RK4 accurate to 1e-6 at dt = 1/40')
  end subroutine test_rk4_order

  !> Output sensitivities of a 2-state, 1-input, 2-output model with state
  !> feedback against central differences, for model parameters (state
  !> biases bx among them), x0, bias, the output delays (one leading) and the
  !> input's delay.
  subroutine test_sensitivities()
    class(model_t), allocatable :: m
    type(options_t) :: opt
    type(param_map_t) :: pm
    real(wp) :: theta(2*2 + 2 + 2*2 + 2 + 2 + 2 + 2 + 2 + 2 + 2 + 1 + 4 + 2)
    integer :: isfree(size(theta))
    real(wp), allocatable :: t(:), u(:, :), y(:, :), dy(:, :, :)
    integer, allocatable :: ifree(:)
    integer :: status, j
    real(wp) :: err
    character(len=256) :: msg

    call model_create(MODEL_LINEAR, 2, 1, 2, 0, [integer ::], [real(wp) ::], m, status, msg)
    ! F = [[-1.2, 0.8], [-0.5, -0.3]] col-major, G, H = [[1, 0.2], [0, 1]], D, K, bx, x0, bias, r
    theta = [-1.2_wp, -0.5_wp, 0.8_wp, -0.3_wp, 0.4_wp, -1.1_wp, 1.0_wp, 0.0_wp, 0.2_wp, 1.0_wp, &
             0.05_wp, -0.02_wp, 0.3_wp, -0.2_wp, 0.05_wp, -0.1_wp, 0.3_wp, -0.1_wp, 0.01_wp, &
             0.02_wp, 1.0_wp, 1.0_wp, 0.013_wp, -0.02_wp, 0.031_wp, 0.0_wp, 0.0_wp, 0.0_wp, &
             0.0_wp, 0.0_wp, 0.0_wp]
    ifree = [1, 3, 4, 6, 9, 12, 13, 14, 15, 16, 17, 18, 20, 23, 24, 25]   ! ... delay udelay
    isfree = 0
    isfree(ifree) = 1
    call param_map_create(model_layout(m), isfree, no_ties(size(theta)), pm, status, msg)
    allocate (t(101), u(1, 101), y(2, 101), dy(2, size(ifree), 101))
    t = [(0.05_wp*j, j=0, 100)]
    u(1, :) = sin(2.0_wp*t) + merge(1.0_wp, 0.0_wp, t > 1.0_wp)
    call oe_predict(m, theta, pm, t, u, opt, y, status, msg, dy=dy)
    err = central_difference_error(m, theta, pm%l, ifree, t, u, dy)
    call check(err < 1.0e-7_wp, 'output sensitivities match central differences (F, G, H, D, K, '// &
               'bx, x0, bias, delay, udelay)')
  end subroutine test_sensitivities

  !> A term whose factor is zero passes nothing to the rest of its
  !> expression, even where its own partial is infinite: k*sqrt(x) at k = 0,
  !> x = 0 has df/dx = 0 (not 0*Inf = NaN); likewise e*sqrt(k) shared by
  !> three outputs.
  subroutine test_infinite_partial_unused()
    character(len=*), parameter :: one = 'u e'//new_line('a')//'p k'//new_line('a')// &
      'x x1 = k*sqrt(x1) + e'//new_line('a')//'y y1 = x1'
    character(len=*), parameter :: three = 'u e'//new_line('a')//'p k'//new_line('a')// &
      'l s = e*sqrt(k)'//new_line('a')//'y y1 = s + 1'//new_line('a')//'y y2 = 2*s'// &
      new_line('a')//'y y3 = s*s + e'
    class(model_t), allocatable :: m
    real(wp) :: xd(1), a(1, 1), b(1, 1), c(3, 0), d(3, 1), none(0)
    integer :: status
    character(len=256) :: msg
    call model_create(MODEL_EQUATIONS, 1, 1, 1, 0, equations_text_codes(one), [real(wp) ::], m, &
                      status, msg)
    call m%eval(0.0_wp, [0.0_wp], [0.5_wp], [0.0_wp], [1], xdot=xd, a=a, b=b)
    call check(a(1, 1) == 0.0_wp, 'k*sqrt(x) at k = 0, x = 0: df/dx = 0 (no 0*Inf)')
    call model_create(MODEL_EQUATIONS, 0, 1, 3, 0, equations_text_codes(three), [real(wp) ::], &
                      m, status, msg)
    call m%eval(0.0_wp, none, [0.0_wp], [0.0_wp], [1], c=c, d=d)
    call check(all(d(:, 1) == 0.0_wp), 'e*sqrt(k) at e = 0, k = 0 in three outputs: dh/dk = 0')
  end subroutine test_infinite_partial_unused

  !> The largest difference, relative to the column's size (at least 1),
  !> between the output sensitivities dy of the free entries ifree and
  !> central differences of whole predictions.
  real(wp) function central_difference_error(m, theta, l, ifree, t, u, dy) result(err)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), t(:), u(:, :), dy(:, :, :)
    type(layout_t), intent(in) :: l
    integer, intent(in) :: ifree(:)
    type(options_t) :: opt
    type(param_map_t) :: none
    real(wp) :: tp(size(theta)), tm(size(theta)), yp(size(dy, 1), size(t)), &
                ym(size(dy, 1), size(t))
    real(wp), parameter :: h = 1.0e-6_wp
    integer :: k, status
    character(len=256) :: msg
    call param_map_create(l, [(0, k=1, size(theta))], no_ties(size(theta)), none, status, msg)
    err = 0.0_wp
    do k = 1, size(ifree)
      tp = theta
      tm = theta
      tp(ifree(k)) = tp(ifree(k)) + h
      tm(ifree(k)) = tm(ifree(k)) - h
      call oe_predict(m, tp, none, t, u, opt, yp, status, msg)
      call oe_predict(m, tm, none, t, u, opt, ym, status, msg)
      err = max(err, maxval(abs((yp - ym)/(2*h) - dy(:, k, :)))/max(1.0_wp, maxval(abs(dy(:, k, :)))))
    end do
  end function central_difference_error

  !> Analytic Jacobians of the longitudinal model (every regressor used)
  !> against central differences.
  !> check_jacobians checks the evaluation of everything at once (what the
  !> output-error integration uses at each sample) against its parts.
  subroutine test_split_evaluation()
    type(split_model_t) :: m
    real(wp) :: err(6)
    m%nx = 1
    m%nu = 1
    m%ny = 1
    m%np = 1
    call check_jacobians(m, 0.0_wp, [0.4_wp], [0.2_wp], [-1.5_wp], err)
    call check(maxval(err) < 1.0e-8_wp, 'a model whose parts agree passes the check')
    m%slip = 1.0e-3_wp
    call check_jacobians(m, 0.0_wp, [0.4_wp], [0.2_wp], [-1.5_wp], err)
    call check(err(1) > 0.5e-3_wp, 'df/dx of the evaluation of everything at once that '// &
               'disagrees with df/dx alone is caught')
  end subroutine test_split_evaluation

  subroutine test_aero_jacobians()
    class(model_t), allocatable :: m
    ! inputs delta_e, thrust, then the four process-noise values
    real(wp), parameter :: x(4) = [95.0_wp, 0.12_wp, 0.08_wp, 0.03_wp], &
                           u(6) = [-0.02_wp, 1.2e4_wp, 0.3_wp, -0.01_wp, 0.002_wp, 0.05_wp]
    real(wp) :: p(13), err, errs(6)
    integer :: status
    character(len=256) :: msg

    ! C_D: 1, V/V0, alpha, alpha^2; C_L: 1, alpha, qhat; C_m: 1, V/V0, alpha, alpha^2, qhat, de
    call model_create(MODEL_AERO_LONG, 4, 2, 7, 4, [4, 3, 6, 1, 2, 3, 4, 1, 3, 5, 1, 2, 3, 4, 5, 6], &
                      [9.80665_wp, 4.028e-3_wp, 8.0027e-4_wp, -7.0153e-6_wp, 104.67_wp, 7472.0_wp, &
                       0.0524_wp, 0.792_wp, 1.215_wp], m, status, msg)
    call check(status == MLID_OK, 'longitudinal model created: '//trim(msg))
    if (status /= MLID_OK) return
    p = [0.1_wp, -0.05_wp, 0.23_wp, 0.8_wp, -0.2_wp, 3.2_wp, 6.0_wp, 0.13_wp, -0.014_wp, -1.0_wp, &
         -0.4_wp, -27.0_wp, -1.4_wp]
    call check_jacobians(m, 0.0_wp, x, u, p, errs)
    err = maxval(errs)
    call check(err < 1.0e-7_wp, 'longitudinal model: df/dx, df/dp, dh/dx, dh/dp, df/dw match '// &
               'central differences')
  end subroutine test_aero_jacobians

  !> The longitudinal model's parameters in any layout the deck allows: a
  !> coefficient's regressors out of order and one named twice (its terms
  !> add), a coefficient without regressors.  Its Jacobians match central
  !> differences; the model equals the one with the repeated regressor's
  !> parameters summed, to rounding; and asked for a shuffled subset of the
  !> parameters, or all of them shuffled, df/dp and dh/dp are the full ones'
  !> columns, to the bit.
  subroutine test_aero_parameter_layouts()
    class(model_t), allocatable :: m, ms
    real(wp), parameter :: x(4) = [101.0_wp, -0.04_wp, 0.09_wp, -0.05_wp], u(2) = [0.03_wp, 9.0e3_wp]
    real(wp), parameter :: rconst(9) = [9.80665_wp, 4.028e-3_wp, 8.0027e-4_wp, -7.0153e-6_wp, &
                                        104.67_wp, 7472.0_wp, 0.0524_wp, 0.792_wp, 1.215_wp]
    ! C_D: alpha, 1, alpha; C_L: none; C_m: de, qhat, V/V0, alpha^2
    real(wp), parameter :: p(7) = [0.4_wp, 0.02_wp, 0.3_wp, -1.1_wp, -25.0_wp, 0.05_wp, -0.6_wp]
    integer, parameter :: sub(4) = [6, 2, 7, 4], perm(7) = [3, 1, 7, 2, 6, 4, 5]
    real(wp) :: errs(6), f(4), a(4, 4), b(4, 7), y(7), c(7, 4), d(7, 7), bp(4, 7), dp(7, 7)
    real(wp) :: fs(4), as(4, 4), bs(4, 4), ys(7), cs(7, 4), ds(7, 4)
    integer :: status, k
    character(len=256) :: msg

    call model_create(MODEL_AERO_LONG, 4, 2, 7, 4, [3, 0, 4, 3, 1, 3, 6, 5, 2, 4], rconst, m, &
                      status, msg)
    call check(status == MLID_OK, 'longitudinal model, regressors in any order: created: '//trim(msg))
    if (status /= MLID_OK) return
    call check_jacobians(m, 0.0_wp, x, u, p, errs)
    call check(maxval(errs) < 1.0e-7_wp, 'longitudinal model, a regressor named twice, a '// &
               'coefficient without regressors: the Jacobians match central differences')

    ! the same model with C_D's two alpha terms as one: C_D: 1, alpha
    call model_create(MODEL_AERO_LONG, 4, 2, 7, 4, [2, 0, 4, 1, 3, 6, 5, 2, 4], rconst, ms, &
                      status, msg)
    call check(status == MLID_OK, 'longitudinal model, each regressor once: created: '//trim(msg))
    if (status /= MLID_OK) return
    call m%eval(0.0_wp, x, u, p, [(k, k=1, 7)], xdot=f, a=a, y=y, c=c)
    call ms%eval(0.0_wp, x, u, [p(2), p(1) + p(3), p(4:7)], [(k, k=1, 6)], xdot=fs, a=as, y=ys, &
                 c=cs)
    call check(maxval(abs(f - fs)/(1.0_wp + abs(f))) < 1.0e-13_wp .and. &
               maxval(abs(a - as)/(1.0_wp + abs(a))) < 1.0e-13_wp .and. &
               maxval(abs(y - ys)/(1.0_wp + abs(y))) < 1.0e-13_wp .and. &
               maxval(abs(c - cs)/(1.0_wp + abs(c))) < 1.0e-13_wp, &
               'longitudinal model: a regressor named twice adds its terms')

    call m%eval(0.0_wp, x, u, p, [(k, k=1, 7)], xdot=f, a=a, b=b, y=y, c=c, d=d)
    call m%eval(0.0_wp, x, u, p, sub, xdot=fs, a=as, b=bs, y=ys, c=cs, d=ds)
    call check(all(fs == f) .and. all(as == a) .and. all(ys == y) .and. all(cs == c) .and. &
               all(bs == b(:, sub)) .and. all(ds == d(:, sub)), 'longitudinal model: a '// &
               'shuffled subset of the parameters gets the full Jacobians'' columns')
    ! every parameter, not in order: the Jacobians' columns come out in
    ! idx's order, asked for everything, for a stage's part and for an
    ! output's part
    call m%eval(0.0_wp, x, u, p, perm, xdot=fs, a=as, b=bp, y=ys, c=cs, d=dp)
    call check(all(fs == f) .and. all(as == a) .and. all(ys == y) .and. all(cs == c) .and. &
               all(bp == b(:, perm)) .and. all(dp == d(:, perm)), 'longitudinal model: every '// &
               'parameter out of order gets the Jacobians'' columns in that order')
    call m%eval(0.0_wp, x, u, p, perm, xdot=fs, a=as, b=bp)
    call check(all(fs == f) .and. all(as == a) .and. all(bp == b(:, perm)), 'longitudinal '// &
               'model: a stage''s part, every parameter out of order')
    call m%eval(0.0_wp, x, u, p, perm, y=ys, c=cs, d=dp)
    call check(all(ys == y) .and. all(cs == c) .and. all(dp == d(:, perm)), 'longitudinal '// &
               'model: an output''s part, every parameter out of order')
  end subroutine test_aero_parameter_layouts

  !> A bias per manoeuvre stated with indicator inputs (m1, m2) on a record
  !> of two manoeuvres: each manoeuvre's model has its indicators folded in
  !> (the same values and Jacobians as the whole model there), and the
  !> output sensitivities, the other manoeuvre's bias exactly zero, match
  !> central differences.
  subroutine test_folded_manoeuvres()
    character(len=*), parameter :: text = 'u e'//new_line('a')//'u m1'//new_line('a')// &
      'u m2'//new_line('a')//'p a'//new_line('a')//'p k'//new_line('a')//'p b1'// &
      new_line('a')//'p b2'//new_line('a')//'l b = b1*m1 + b2*m2'//new_line('a')// &
      'x x1 = a*x1 + k*(e - b)'//new_line('a')//'x x2 = x1 - 2*x2*m1 - x2^2*m2'// &
      new_line('a')//'y y1 = x1 + 0.5*b'//new_line('a')//'y y2 = sin(x2)'
    class(model_t), allocatable :: m, mf
    type(options_t) :: opt
    type(param_map_t) :: pm
    ! p(4), x0(2 x 2), bias(2 x 2), r(2), delay(2), udelay(3), stab(2 x 2)
    real(wp) :: theta(4 + 4 + 4 + 2 + 2 + 3 + 4 + 2)
    real(wp) :: xd(2), xdf(2), a(2, 2), af(2, 2), b(2, 4), bf(2, 4), c(2, 2), cf(2, 2), d(2, 4), &
                df(2, 4), err
    integer :: isfree(size(theta)), status, j
    integer, allocatable :: ifree(:)
    logical :: used(4)
    real(wp), allocatable :: t(:), u(:, :), y(:, :), dy(:, :, :)
    character(len=256) :: msg

    call model_create(MODEL_EQUATIONS, 2, 3, 2, 0, equations_text_codes(text), [real(wp) ::], m, &
                      status, msg)
    call check(status == MLID_OK, 'equations model with indicators created: '//trim(msg))
    if (status /= MLID_OK) return
    call m%fold_inputs([.false., .true., .true.], [0.0_wp, 0.0_wp, 1.0_wp], mf)
    call check(allocated(mf), 'the equations model folds inputs it is told are fixed')
    if (.not. allocated(mf)) return
    call mf%uses_params(used)
    call check(all(used .eqv. [.true., .true., .false., .true.]), &
               'over manoeuvre 2 the folded model reads a, k, b2, not b1')
    call m%eval(0.3_wp, [0.7_wp, -0.4_wp], [0.2_wp, 0.0_wp, 1.0_wp], [-1.1_wp, 0.6_wp, 0.2_wp, &
                -0.3_wp], [1, 2, 3, 4], xdot=xd, a=a, b=b, c=c, d=d)
    call mf%eval(0.3_wp, [0.7_wp, -0.4_wp], [0.2_wp, 0.0_wp, 1.0_wp], [-1.1_wp, 0.6_wp, &
                 0.2_wp, -0.3_wp], [1, 2, 3, 4], xdot=xdf, a=af, b=bf, c=cf, d=df)
    call check(all(xd == xdf) .and. all(a == af) .and. all(b == bf) .and. all(c == cf) .and. &
               all(d == df), 'the folded model: the same values and Jacobians, to the bit')

    theta = 0.0_wp
    theta(1:4) = [-0.8_wp, 0.5_wp, 0.15_wp, -0.25_wp]
    theta(5:8) = [0.1_wp, 0.0_wp, -0.2_wp, 0.3_wp]        ! x0 of manoeuvres 1 and 2
    theta(9:12) = [0.01_wp, 0.0_wp, 0.0_wp, -0.02_wp]      ! biases of manoeuvres 1 and 2
    theta(13:14) = 1.0_wp
    ifree = [1, 2, 3, 4, 7, 9, 12]                          ! p, x0(1) of 2, bias(1) of 1, bias(2) of 2
    isfree = 0
    isfree(ifree) = 1
    call param_map_create(model_layout(m, [1, 52]), isfree, no_ties(size(theta)), pm, status, msg)
    allocate (t(101), u(3, 101), y(2, 101), dy(2, size(ifree), 101))
    t = [(0.05_wp*j, j=0, 100)]
    u(1, :) = sin(2.0_wp*t) + merge(1.0_wp, 0.0_wp, t > 1.0_wp)
    u(2, :) = merge(1.0_wp, 0.0_wp, t < 2.53_wp)           ! samples 1-51: manoeuvre 1
    u(3, :) = 1.0_wp - u(2, :)
    call oe_predict(m, theta, pm, t, u, opt, y, status, msg, dy=dy)
    call check(status == MLID_OK, 'two manoeuvres predicted: '//trim(msg))
    call check(all(dy(:, 4, 1:51) == 0.0_wp) .and. all(dy(:, 3, 52:) == 0.0_wp) .and. &
               all(dy(:, 5, 1:51) == 0.0_wp) .and. all(dy(:, 6, 52:) == 0.0_wp) .and. &
               any(dy(:, 3, 1:51) /= 0.0_wp) .and. any(dy(:, 4, 52:) /= 0.0_wp), &
               'a manoeuvre''s bias and initial state move only that manoeuvre')
    err = central_difference_error(m, theta, pm%l, ifree, t, u, dy)
    call check(err < 1.0e-7_wp, 'two manoeuvres with indicators: output sensitivities match '// &
               'central differences')
  end subroutine test_folded_manoeuvres

  subroutine test_linalg()
    real(wp) :: a(3, 3), w(3), v(3, 3), ainv(3, 3), logdet
    integer :: info
    a = reshape([4.0_wp, 1.0_wp, 0.5_wp, 1.0_wp, 3.0_wp, 0.2_wp, 0.5_wp, 0.2_wp, 2.0_wp], [3, 3])
    call sym_eig(a, w, v, info)
    call check(info == 0 .and. maxval(abs(matmul(a, v) - v*spread(w, 1, 3))) < 1.0e-12_wp, &
               'dsyevr eigenpairs satisfy A v = lambda v')
    call check(w(1) <= w(2) .and. w(2) <= w(3), 'eigenvalues ascending')
    call chol_inverse(a, ainv, logdet, info)
    call check(info == 0 .and. maxval(abs(matmul(a, ainv) - eye3())) < 1.0e-12_wp, &
               'Cholesky inverse')
    call check(abs(logdet - log(product(w))) < 1.0e-12_wp, 'log-determinant = sum of log eigenvalues')
    a(3, 3) = -5.0_wp
    call chol_inverse(a, ainv, logdet, info)
    call check(info > 0, 'indefinite matrix reported, not inverted')
    call check_both_choleskys(8)
    call check_both_choleskys(20)
    call test_psd_factor()
  end subroutine test_linalg

  !> psd_factor: a variance 1e-14 times another keeps its factor (the
  !> weights of output error: an output in other units must not drop out),
  !> a singular matrix scaled so gets its zero pivot all the same, an
  !> indefinite one is refused.
  subroutine test_psd_factor()
    real(wp) :: a(2, 2), l(2, 2), d(2, 2)
    logical :: ok
    a = reshape([1.0e-14_wp, 0.0_wp, 0.0_wp, 1.0_wp], [2, 2])
    call psd_factor(a, l, ok)
    call check(ok .and. abs(l(1, 1) - 1.0e-7_wp) < 1.0e-22_wp .and. l(2, 2) == 1.0_wp, &
               'psd_factor keeps a small variable''s factor')
    d = reshape([1.0e-7_wp, 0.0_wp, 0.0_wp, 1.0_wp], [2, 2])
    a = matmul(d, matmul(reshape([1.0_wp, 1.0_wp, 1.0_wp, 1.0_wp], [2, 2]), d))
    call psd_factor(a, l, ok)
    call check(ok .and. l(2, 2) == 0.0_wp .and. maxval(abs(matmul(l, transpose(l)) - a)) < 1.0e-15_wp, &
               'psd_factor: a scaled singular matrix has its zero pivot')
    a = reshape([1.0e-14_wp, 0.0_wp, 0.0_wp, -1.0_wp], [2, 2])
    call psd_factor(a, l, ok)
    call check(.not. ok, 'psd_factor refuses an indefinite matrix')
  end subroutine test_psd_factor

  !> The small-matrix path (n <= 12) and LAPACK's agree with the definition.
  subroutine check_both_choleskys(n)
    integer, intent(in) :: n
    real(wp) :: b(n, n), a(n, n), ainv(n, n), w(n), v(n, n), logdet, e(n, n)
    integer :: i, j, info
    do j = 1, n
      do i = 1, n
        b(i, j) = sin(real(3*i + 7*j, wp))
      end do
    end do
    a = matmul(b, transpose(b))
    e = 0.0_wp
    do i = 1, n
      a(i, i) = a(i, i) + 0.5_wp
      e(i, i) = 1.0_wp
    end do
    call sym_eig(a, w, v, info)
    call chol_inverse(a, ainv, logdet, info)
    call check(info == 0 .and. maxval(abs(matmul(a, ainv) - e)) < 1.0e-10_wp .and. &
               abs(logdet - sum(log(w))) < 1.0e-10_wp, 'Cholesky inverse and log|A| of an SPD matrix')
    ! chol_solve: A x = b to rounding, and a matrix that is not positive definite refused
    call chol_solve(a, b(:, 1), w, info)
    call check(info == 0 .and. maxval(abs(matmul(a, w) - b(:, 1))) < 1.0e-10_wp*maxval(abs(b)), &
               'Cholesky solve of an SPD system')
    a(n, n) = -1.0_wp
    call chol_solve(a, b(:, 1), w, info)
    call check(info == n, 'Cholesky solve refuses a matrix that is not positive definite')
  end subroutine check_both_choleskys

  function eye3() result(e)
    real(wp) :: e(3, 3)
    integer :: i
    e = 0.0_wp
    do i = 1, 3
      e(i, i) = 1.0_wp
    end do
  end function eye3

  !> Same seed, same stream; N(0,1) moments within 5 standard errors.
  subroutine test_random()
    type(rng_t) :: r1, r2
    integer, parameter :: n = 200000
    real(wp) :: z(n), mean, var
    integer :: k
    call rng_seed(r1, 7)
    call rng_seed(r2, 7)
    do k = 1, n
      z(k) = rng_normal(r1)
    end do
    call check(abs(rng_normal(r2) - z(1)) == 0.0_wp, 'same seed gives the same stream')
    mean = sum(z)/n
    var = sum((z - mean)**2)/(n - 1)
    call check(abs(mean) < 5.0_wp/sqrt(real(n, wp)), 'normal mean within 5 standard errors of 0')
    call check(abs(var - 1.0_wp) < 5.0_wp*sqrt(2.0_wp/n), 'normal variance within 5 standard errors of 1')
  end subroutine test_random

end program test_numerics
