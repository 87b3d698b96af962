!> Models that tell param_rows other things than their own: the
!> longitudinal model saying nothing (dense, model_t's default), naming the
!> rows of every other parameter only, or naming a wrong row; and the
!> linear model naming the rows lin_dfdp and lin_dhdp write.
module rows_models
  use mlid_kinds, only: wp
  use mlid_models, only: linear_model_t, NZ_HROWS
  use mlid_aero_long, only: aero_long_t
  implicit none
  private
  public :: dense_long_t, mixed_long_t, wrong_long_t, rows_linear_t

  type, extends(aero_long_t) :: dense_long_t
  contains
    procedure :: param_rows => any_row
  end type dense_long_t

  type, extends(aero_long_t) :: mixed_long_t
  contains
    procedure :: param_rows => every_other_row
  end type mixed_long_t

  type, extends(aero_long_t) :: wrong_long_t
  contains
    procedure :: param_rows => next_row
  end type wrong_long_t

  type, extends(linear_model_t) :: rows_linear_t
  contains
    procedure :: param_rows => linear_rows
  end type rows_linear_t

contains

  pure subroutine any_row(self, idx, frow, hrow)
    class(dense_long_t), intent(in) :: self
    integer, intent(in) :: idx(:)
    integer, intent(out) :: frow(size(idx)), hrow(NZ_HROWS, size(idx))
    frow = 0
    hrow = 0
  end subroutine any_row

  pure subroutine every_other_row(self, idx, frow, hrow)
    class(mixed_long_t), intent(in) :: self
    integer, intent(in) :: idx(:)
    integer, intent(out) :: frow(size(idx)), hrow(NZ_HROWS, size(idx))
    call self%aero_long_t%param_rows(idx, frow, hrow)
    frow(2::2) = 0
    hrow(:, 2::2) = 0
  end subroutine every_other_row

  !> The state equation after the right one: a broken promise.
  pure subroutine next_row(self, idx, frow, hrow)
    class(wrong_long_t), intent(in) :: self
    integer, intent(in) :: idx(:)
    integer, intent(out) :: frow(size(idx)), hrow(NZ_HROWS, size(idx))
    call self%aero_long_t%param_rows(idx, frow, hrow)
    frow = mod(frow, 4) + 1
  end subroutine next_row

  !> F(i, j), G(i, j), Gamma(i, j) and bx(i) move f's row i alone, H(i, j)
  !> and D(i, j) h's row i; K, and what does not enter f or h: any row.
  pure subroutine linear_rows(self, idx, frow, hrow)
    class(rows_linear_t), intent(in) :: self
    integer, intent(in) :: idx(:)
    integer, intent(out) :: frow(size(idx)), hrow(NZ_HROWS, size(idx))
    integer :: k, q
    frow = 0
    hrow = 0
    do k = 1, size(idx)
      q = idx(k)
      if (q <= self%oh) then                               ! F, G
        frow(k) = mod(q - 1, self%nx) + 1
      else if (q <= self%ogam) then                        ! H, D
        hrow(1, k) = mod(q - self%oh - 1, self%ny) + 1
      else if (q <= self%ok) then                          ! Gamma
        frow(k) = mod(q - self%ogam - 1, self%nx) + 1
      else if (q > self%obx) then                          ! bx
        frow(k) = q - self%obx
      end if
    end do
  end subroutine linear_rows

end module rows_models

module param_rows_checks
  use, intrinsic :: iso_fortran_env, only: int64
  use mlid_kinds, only: wp, MLID_OK
  use mlid_models, only: model_t, linear_model_t, model_layout, layout_t, NZ_HROWS
  use mlid_model_factory, only: model_create, MODEL_LINEAR
  use mlid_aero_long, only: aero_long_t, aero_long_create
  use mlid_rk, only: rk4_step, rk_work_t, rk_work_size, input_sens_t
  use mlid_params, only: param_map_t, param_map_create, no_ties
  use mlid_options, only: options_t
  use mlid_filter, only: oe_predict, kf_innovations
  use mlid_random, only: rng_t, rng_seed, rng_normal
  use mlid_text, only: itoa
  use test_checks, only: check, finish
  use rows_models, only: dense_long_t, mixed_long_t, wrong_long_t, rows_linear_t
  implicit none
  private
  public :: run_checks

  ! C_D: 1, V/V0, alpha, alpha^2; C_L: 1, alpha, qhat; C_m: 1, V/V0, alpha, alpha^2, qhat, de
  integer, parameter :: ICONST(16) = [4, 3, 6, 1, 2, 3, 4, 1, 3, 5, 1, 2, 3, 4, 5, 6]
  real(wp), parameter :: RCONST(9) = [9.80665_wp, 4.028e-3_wp, 8.0027e-4_wp, -7.0153e-6_wp, &
                                      104.67_wp, 7472.0_wp, 0.0524_wp, 0.792_wp, 1.215_wp]
  real(wp), parameter :: P(13) = [0.1_wp, -0.05_wp, 0.23_wp, 0.8_wp, -0.2_wp, 3.2_wp, 6.0_wp, &
                                  0.13_wp, -0.014_wp, -1.0_wp, -0.4_wp, -27.0_wp, -1.4_wp]
  type(aero_long_t) :: al
  type(dense_long_t) :: dl
  type(mixed_long_t) :: ml
  type(wrong_long_t) :: wl
  type(rows_linear_t) :: lin
  integer :: status
  character(len=256) :: msg

contains

  subroutine run_checks()
    call aero_long_create(ICONST, RCONST, al, status, msg)
    call check(status == MLID_OK, 'longitudinal model created: '//trim(msg))
    call aero_long_create(ICONST, RCONST, dl%aero_long_t, status, msg)
    call aero_long_create(ICONST, RCONST, ml%aero_long_t, status, msg)
    call aero_long_create(ICONST, RCONST, wl%aero_long_t, status, msg)
    call linear_with_rows(lin)
    call test_aero_rows()
    call test_linear_rows()
    call test_default_dense()
    call test_rk4_forcing_aero()
    call test_rk4_forcing_linear()
    call test_output_sensitivities()
    call test_filter_sensitivities()
    call finish()
  end subroutine run_checks

  !> A linear model of 3 states, 1 input and 2 outputs that names its rows.
  subroutine linear_with_rows(m)
    type(rows_linear_t), intent(out) :: m
    class(model_t), allocatable :: mm
    call model_create(MODEL_LINEAR, 3, 1, 2, 0, [integer ::], [real(wp) ::], mm, status, msg)
    select type (mm)
    type is (linear_model_t)
      m%linear_model_t = mm
    end select
  end subroutine linear_with_rows

  !> Whether eval's b and d at (x, u, p) are exactly zero outside the rows
  !> param_rows names for idx; with sharp, also whether it names rows for
  !> every parameter and b's row and d's first are nonzero there.
  logical function rows_hold(m, x, u, p, idx, sharp) result(ok)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    logical, intent(in) :: sharp
    real(wp) :: b(m%nx, size(idx)), d(m%ny, size(idx))
    integer :: frow(size(idx)), hrow(NZ_HROWS, size(idx)), k, i
    call m%eval(0.0_wp, x, u, p, idx, b=b, d=d)
    call m%param_rows(idx, frow, hrow)
    ok = .true.
    do k = 1, size(idx)
      do i = 1, m%nx
        if (frow(k) > 0 .and. i /= frow(k)) ok = ok .and. b(i, k) == 0.0_wp
      end do
      do i = 1, m%ny
        if (hrow(1, k) > 0 .and. .not. any(hrow(:, k) == i)) ok = ok .and. d(i, k) == 0.0_wp
      end do
      if (.not. sharp) cycle
      if (frow(k) < 1 .or. hrow(1, k) < 1) then
        ok = .false.
      else
        ok = ok .and. b(frow(k), k) /= 0.0_wp .and. d(hrow(1, k), k) /= 0.0_wp
      end if
    end do
  end function rows_hold

  !> A random point of the longitudinal model: V 60..140 m/s, angles and
  !> rate of some 0.1 rad, elevator and thrust.
  subroutine aero_point(r, x, u)
    type(rng_t), intent(inout) :: r
    real(wp), intent(out) :: x(4), u(2)
    x = [100.0_wp + 20.0_wp*rng_normal(r), 0.1_wp*rng_normal(r), 0.1_wp*rng_normal(r), &
         0.1_wp*rng_normal(r)]
    u = [0.05_wp*rng_normal(r), 1.0e4_wp + 2.0e3_wp*rng_normal(r)]
  end subroutine aero_point

  !> The longitudinal model's rows (brow's state equation, the outputs of its
  !> coefficient) at random points and parameters, for every parameter, a
  !> shuffled subset, and a second layout (a regressor named twice, C_L
  !> without regressors); a wrong row is caught.
  subroutine test_aero_rows()
    type(aero_long_t) :: a2
    type(rng_t) :: r
    real(wp) :: x(4), u(2), pr(13)
    integer :: j, k
    logical :: ok, ok2, caught
    call aero_long_create([3, 0, 4, 3, 1, 3, 6, 5, 2, 4], RCONST, a2, status, msg)
    call rng_seed(r, 31)
    ok = .true.
    ok2 = .true.
    caught = .true.
    do j = 1, 25
      call aero_point(r, x, u)
      pr = [(P(k)*(1.0_wp + 0.5_wp*rng_normal(r)), k=1, 13)]
      ok = ok .and. rows_hold(al, x, u, pr, [(k, k=1, 13)], .true.)
      ok = ok .and. rows_hold(al, x, u, pr, [13, 2, 7, 5, 11], .true.)
      ok2 = ok2 .and. rows_hold(a2, x, u, pr(1:7), [(k, k=1, 7)], .true.)
      caught = caught .and. .not. rows_hold(wl, x, u, pr, [(k, k=1, 13)], .false.)
    end do
    call check(ok, 'longitudinal model: df/dp and dh/dp zero outside param_rows'' rows, '// &
               'nonzero in them, at 25 random points (every parameter, a shuffled subset)')
    call check(ok2, 'longitudinal model, a regressor named twice, a coefficient without '// &
               'regressors: the same')
    call check(caught, 'a model naming the wrong row of df/dp is caught by the same check')
  end subroutine test_aero_rows

  !> The test's linear model names true rows (so that the steps below test
  !> the forcing, not a broken promise).
  subroutine test_linear_rows()
    type(rng_t) :: r
    real(wp) :: pr(lin%np), x(3), u(1)
    integer :: j, k
    logical :: ok
    call rng_seed(r, 32)
    ok = .true.
    do j = 1, 10
      pr = [(rng_normal(r), k=1, lin%np)]
      x = [(rng_normal(r), k=1, 3)]
      u = rng_normal(r)
      ok = ok .and. rows_hold(lin, x, u, pr, [(k, k=1, lin%np)], .false.)
    end do
    call check(ok, 'linear model naming F''s, G''s, Gamma''s, bx''s, H''s and D''s rows: '// &
               'df/dp and dh/dp zero outside them')
  end subroutine test_linear_rows

  !> model_t's default: every row, and the forcing stays dense.
  subroutine test_default_dense()
    class(model_t), allocatable :: m
    type(rk_work_t) :: wk
    integer :: frow(5), hrow(NZ_HROWS, 5)
    call model_create(MODEL_LINEAR, 3, 1, 2, 0, [integer ::], [real(wp) ::], m, status, msg)
    call m%param_rows([1, 4, 10, 17, 25], frow, hrow)
    call check(all(frow == 0) .and. all(hrow == 0), 'model_t''s param_rows: any row')
    call rk_work_size(wk, 3, 4, 5, 1, 1, m, [1, 4, 10, 17, 25])
    call check(.not. any(wk%frow > 0), 'a dense model''s forcing stays dense')
    call rk_work_size(wk, 4, 4, 5, 2, 6, al, [1, 4, 10, 12, 13])
    call check(any(wk%frow > 0) .and. all(wk%frow == [1, 1, 4, 4, 4]), 'the longitudinal model''s '// &
               'forcing by rows: C_D''s state equation 1, C_m''s 4')
    call rk_work_size(wk, 4, 5, 5, 2, 6)
    call check(.not. any(wk%frow > 0), 'work arrays sized anew without the model: dense again')
  end subroutine test_default_dense

  !> 25 RK4 steps of the longitudinal model's state and sensitivities, every
  !> parameter forcing (shuffled, two of them tied into one column with a
  !> scale), with and without a constant forcing sforce: with the rows known
  !> (sparse), told dense, with every other row known, and untold, the
  !> states and sensitivities are the same to the bit; a wrong row is not.
  subroutine test_rk4_forcing_aero()
    integer, parameter :: ns = 12, nb = 13
    integer, parameter :: idxm(nb) = [5, 1, 9, 13, 2, 7, 11, 3, 12, 4, 8, 6, 10], &
                          colm(nb) = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 3, 12]
    real(wp) :: wcol(nb), s0(4, ns), sf(4, ns), x(4, 5), s(4, ns, 5)
    type(rng_t) :: r
    integer :: i, k, j
    logical :: sparse(5), same
    call rng_seed(r, 33)
    wcol = 1.0_wp
    wcol(12) = -0.37_wp
    s0 = reshape([(0.1_wp*rng_normal(r), k=1, 4*ns)], [4, ns])
    s0(:, 6) = 0.0_wp                 ! a column from zero, as at a record's start
    sf = reshape([(0.01_wp*rng_normal(r), k=1, 4*ns)], [4, ns])
    do j = 1, 2
      call steps(al, .true., x(:, 1), s(:, :, 1), sparse(1))
      call steps(dl, .true., x(:, 2), s(:, :, 2), sparse(2))
      call steps(ml, .true., x(:, 3), s(:, :, 3), sparse(3))
      call steps(al, .false., x(:, 4), s(:, :, 4), sparse(4))
      call steps(wl, .true., x(:, 5), s(:, :, 5), sparse(5))
      call check(all(sparse .eqv. [.true., .false., .true., .false., .true.]), &
                 'RK4 forcing: sparse where the rows are told (run '//itoa(j)//')')
      same = .true.
      do i = 2, 4
        same = same .and. bits_equal(x(:, i), x(:, 1)) .and. bits_equal(s(:, :, i), s(:, :, 1))
      end do
      call check(same, 'RK4 states and sensitivities with df/dp''s rows known, told dense, '// &
                 'every other row known and untold: the same to the bit, a tie among the '// &
                 'columns'//trim(merge(', sforce given', '              ', j == 2)))
      call check(.not. bits_equal(s(:, :, 5), s(:, :, 1)), 'RK4 sensitivities with a wrong '// &
                 'row of df/dp differ (run '//itoa(j)//')')
    end do

  contains

    subroutine steps(m, tell, xe, se, sp)
      class(model_t), intent(in) :: m
      logical, intent(in) :: tell
      real(wp), intent(out) :: xe(4), se(4, ns)
      logical, intent(out) :: sp
      type(rk_work_t) :: wk
      real(wp) :: ua(6), ub(6), t
      integer :: n
      if (tell) then
        call rk_work_size(wk, 4, ns, nb, 2, 6, m, idxm)
      else
        call rk_work_size(wk, 4, ns, nb, 2, 6)
      end if
      xe = [95.0_wp, 0.12_wp, 0.08_wp, 0.03_wp]
      se = s0
      do n = 1, 25
        t = 0.05_wp*(n - 1)
        ua = [0.03_wp*sin(t), 1.2e4_wp, 0.0_wp, 0.0_wp, 0.0_wp, 0.0_wp]
        ub = [0.03_wp*sin(t + 0.05_wp), 1.2e4_wp, 0.0_wp, 0.0_wp, 0.0_wp, 0.0_wp]
        if (j == 1) then
          call rk4_step(m, P, t, 0.05_wp, ua, ub, xe, idxm, colm, wcol, wk, se)
        else
          call rk4_step(m, P, t, 0.05_wp, ua, ub, xe, idxm, colm, wcol, wk, se, sf)
        end if
      end do
      sp = any(wk%frow > 0)          ! after the steps: none of them forgot the rows
    end subroutine steps

  end subroutine test_rk4_forcing_aero

  !> The same for the linear model (three states: the forcing's general
  !> size), its rows known for some parameters and not for others (K), a
  !> tie, sforce and a delayed input forcing a column.
  subroutine test_rk4_forcing_linear()
    integer, parameter :: ns = 9
    class(model_t), allocatable :: base
    type(rng_t) :: r
    type(input_sens_t) :: us
    real(wp) :: pr(lin%np), s0(3, ns), sf(3, ns), x1(3), x2(3), s1(3, ns), s2(3, ns)
    real(wp), allocatable :: wcol(:)
    integer, allocatable :: idxm(:), colm(:)
    integer :: k
    logical :: sp1, sp2
    call model_create(MODEL_LINEAR, 3, 1, 2, 0, [integer ::], [real(wp) ::], base, status, msg)
    call rng_seed(r, 34)
    pr = [(0.3_wp*rng_normal(r), k=1, lin%np)]
    pr(1:9:4) = pr(1:9:4) - 1.0_wp           ! F's diagonal: a stable model
    ! p = [F(1:9), G(10:12), H(13:18), D(19:20), K(21:23), bx(24:26)], no Gamma
    idxm = [22, 1, 5, 13, 24, 9, 3, 21, 16, 12, 7, 14, 19]
    colm = [1, 2, 3, 4, 5, 6, 7, 8, 9, 2, 3, 9, 6]         ! ties into 2, 3, 6 and 9
    wcol = [(1.0_wp, k=1, size(idxm))]
    wcol(10) = 2.5_wp
    wcol(13) = -0.8_wp
    s0 = reshape([(0.1_wp*rng_normal(r), k=1, 3*ns)], [3, ns])
    sf = reshape([(0.01_wp*rng_normal(r), k=1, 3*ns)], [3, ns])
    us = input_sens_t([1], [4], [0.3_wp], [-0.2_wp])
    call steps(lin, x1, s1, sp1)
    call steps(base, x2, s2, sp2)
    call check(sp1 .and. .not. sp2, 'linear model: sparse forcing where the rows are told')
    call check(bits_equal(x1, x2) .and. bits_equal(s1, s2), 'linear model, 3 states: RK4 '// &
               'states and sensitivities with the rows of some parameters known and without: '// &
               'the same to the bit (a tie, sforce, a delayed input)')

  contains

    subroutine steps(m, xe, se, sp)
      class(model_t), intent(in) :: m
      real(wp), intent(out) :: xe(3), se(3, ns)
      logical, intent(out) :: sp
      type(rk_work_t) :: wk
      real(wp) :: t
      integer :: n
      call rk_work_size(wk, 3, ns, size(idxm), 1, 1, m, idxm)
      xe = [0.4_wp, -0.2_wp, 0.1_wp]
      se = s0
      do n = 1, 20
        t = 0.1_wp*(n - 1)
        call rk4_step(m, pr, t, 0.1_wp, [sin(t)], [sin(t + 0.1_wp)], xe, idxm, colm, wcol, wk, &
                      se, sf, us, [0.0_wp, 1.0_wp])
      end do
      sp = any(wk%frow > 0)          ! after the steps: none of them forgot the rows
    end subroutine steps

  end subroutine test_rk4_forcing_linear

  !> The output error's outputs and sensitivities of the longitudinal model
  !> (its parameters, an initial state and a bias free) with param_rows
  !> known and told dense: the same to the bit (the forcing, and the
  !> outputs' dh/dp added in its last three rows alone).
  subroutine test_output_sensitivities()
    type(layout_t) :: l
    type(param_map_t) :: pm
    type(options_t) :: opt
    real(wp), allocatable :: theta(:), t(:), u(:, :), y1(:, :), y2(:, :), dy1(:, :, :), &
                             dy2(:, :, :)
    integer, allocatable :: isfree(:)
    integer :: j, st1, st2
    l = model_layout(al)
    allocate (theta(l%nth), isfree(l%nth), t(121), u(2, 121), y1(7, 121), y2(7, 121))
    theta = 0.0_wp
    theta(1:13) = P
    theta(l%ox0 + 1:l%ox0 + 4) = [95.0_wp, 0.12_wp, 0.08_wp, 0.03_wp]
    theta(l%or + 1:l%or + 7) = 1.0_wp
    isfree = 0
    isfree(1:13) = 1
    isfree(l%ox0 + 2) = 1
    isfree(l%obias + 6) = 1
    call param_map_create(l, isfree, no_ties(l%nth), pm, status, msg)
    call check(status == MLID_OK, 'parameter map: '//trim(msg))
    allocate (dy1(7, pm%nf, 121), dy2(7, pm%nf, 121))
    t = [(0.05_wp*j, j=0, 120)]
    u(1, :) = merge(0.03_wp, 0.0_wp, t > 1.0_wp .and. t < 2.0_wp) &
              - merge(0.03_wp, 0.0_wp, t >= 2.0_wp .and. t < 3.0_wp)
    u(2, :) = 1.2e4_wp
    call oe_predict(al, theta, pm, t, u, opt, y1, st1, msg, dy=dy1)
    call oe_predict(dl, theta, pm, t, u, opt, y2, st2, msg, dy=dy2)
    call check(st1 == MLID_OK .and. st2 == MLID_OK .and. maxval(abs(dy1)) > 0.0_wp, &
               'output error predictions of the longitudinal model')
    call check(bits_equal(y1, y2) .and. bits_equal(dy1, dy2), 'output error outputs and '// &
               'sensitivities with param_rows known and told dense: the same to the bit')
  end subroutine test_output_sensitivities

  !> The filter error's innovations, their sensitivities and B's (the
  !> extended Kalman filter and the steady gain, with the partials; the
  !> coefficients, an initial state, q(1) and r(6) free) with param_rows
  !> known and told dense: the same to the bit.
  subroutine test_filter_sensitivities()
    integer, parameter :: N = 121
    type(layout_t) :: l
    type(param_map_t) :: pm
    type(options_t) :: opt
    real(wp), allocatable :: theta(:), t(:), u(:, :), y(:, :), yh(:, :, :), nu(:, :, :), &
                             bi(:, :, :, :), ld(:, :), dnu(:, :, :, :), db(:, :, :, :, :)
    integer, allocatable :: isfree(:)
    integer :: j, k, st(2)
    l = model_layout(al)
    allocate (theta(l%nth), isfree(l%nth), t(N), u(2, N), y(7, N))
    theta = 0.0_wp
    theta(1:13) = P
    theta(l%ox0 + 1:l%ox0 + 4) = [95.0_wp, 0.12_wp, 0.08_wp, 0.03_wp]
    theta(l%or + 1:l%or + 7) = 1.0e-4_wp
    theta(l%oq + 1:l%oq + 4) = [1.0e-2_wp, 1.0e-4_wp, 0.0_wp, 1.0e-4_wp]
    isfree = 0
    isfree(1:13) = 1
    isfree([l%ox0 + 2, l%oq + 1, l%or + 6]) = 1
    call param_map_create(l, isfree, no_ties(l%nth), pm, status, msg)
    t = [(0.05_wp*j, j=0, N - 1)]
    u(1, :) = merge(0.03_wp, 0.0_wp, t > 1.0_wp .and. t < 2.0_wp) &
              - merge(0.03_wp, 0.0_wp, t >= 2.0_wp .and. t < 3.0_wp)
    u(2, :) = 1.2e4_wp
    call oe_predict(al, theta, pm, t, u, opt, y, status, msg)
    y = y + 0.01_wp*sin(reshape([(real(j, wp), j=1, 7*N)], [7, N]))    ! residuals to filter
    allocate (yh(7, N, 2), nu(7, N, 2), bi(7, 7, N, 2), ld(N, 2), dnu(7, pm%nf, N, 2), &
              db(7, 7, pm%nf, N, 2))
    do j = 1, 2
      opt%steady = j == 2
      call kf_innovations(al, theta, pm, t, u, y, opt, yh(:, :, 1), nu(:, :, 1), bi(:, :, :, 1), &
                          ld(:, 1), st(1), msg, dnu=dnu(:, :, :, 1), db=db(:, :, :, :, 1))
      call kf_innovations(dl, theta, pm, t, u, y, opt, yh(:, :, 2), nu(:, :, 2), bi(:, :, :, 2), &
                          ld(:, 2), st(2), msg, dnu=dnu(:, :, :, 2), db=db(:, :, :, :, 2))
      k = size(db(:, :, :, :, 1))
      call check(all(st == MLID_OK) .and. maxval(abs(dnu)) > 0.0_wp .and. &
                 bits_equal(nu(:, :, 1), nu(:, :, 2)) .and. &
                 bits_equal(dnu(:, :, :, 1), dnu(:, :, :, 2)) .and. &
                 bits_equal(reshape(db(:, :, :, :, 1), [k]), reshape(db(:, :, :, :, 2), [k])), &
                 'filter error ('//trim(merge('steady gain    ', 'extended Kalman',  &
                 opt%steady))//'): innovations, their and B''s sensitivities with param_rows '// &
                 'known and told dense, the same to the bit')
      call kf_innovations(wl, theta, pm, t, u, y, opt, yh(:, :, 2), nu(:, :, 2), bi(:, :, :, 2), &
                          ld(:, 2), st(2), msg, dnu=dnu(:, :, :, 2), db=db(:, :, :, :, 2))
      call check(.not. bits_equal(dnu(:, :, :, 1), dnu(:, :, :, 2)), 'filter error: a wrong '// &
                 'row of df/dp changes the innovations'' sensitivities')
    end do
  end subroutine test_filter_sensitivities

  !> a and b the same to the bit (a zero's sign included).
  logical function bits_equal(a, b)
    real(wp), intent(in) :: a(..), b(..)
    bits_equal = .false.
    select rank (a)
    rank (1)
      select rank (b)
      rank (1)
        bits_equal = all(transfer(a, 1_int64, size(a)) == transfer(b, 1_int64, size(b)))
      end select
    rank (2)
      select rank (b)
      rank (2)
        bits_equal = all(transfer(a, 1_int64, size(a)) == transfer(b, 1_int64, size(b)))
      end select
    rank (3)
      select rank (b)
      rank (3)
        bits_equal = all(transfer(a, 1_int64, size(a)) == transfer(b, 1_int64, size(b)))
      end select
    end select
  end function bits_equal

end module param_rows_checks

!> model_t%param_rows and what uses it: the longitudinal model's rows of
!> df/dp and dh/dp against its dense b and d at random points (outside them
!> exactly zero); the RK4 sensitivity steps and the output error's output
!> sensitivities with the rows known against those without, to the bit
!> (ties, sforce, a mixed and a dense model, delayed inputs included).
program test_param_rows
  use param_rows_checks, only: run_checks
  implicit none
  call run_checks()
end program test_param_rows
