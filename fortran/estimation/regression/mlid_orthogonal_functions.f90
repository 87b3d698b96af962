!> Multivariate orthogonal functions (Morelli; Klein and Morelli 2006,
!> sec. 5.4.2): the candidates are orthogonalised by modified Gram-Schmidt
!> in the order of their contribution, each step taking the candidate whose
!> orthogonal function p (its part not explained by the functions before)
!> most reduces the residual sum of squares, (p'y)^2/(p'p); the number of
!> functions is the one of least predicted square error
!>   PSE = SSE/N + sig2_max p/N;
!> and the model goes back to the ordinary regressors by least squares on
!> the candidates of the chosen functions (they span the same space, so this
!> is the triangular back-substitution of the orthogonal expansion).  The
!> forced terms (the constant) are the first functions, always kept.
module mlid_orthogonal_functions
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_MEMORY
  use mlid_text, only: itoa
  use mlid_regression, only: regression_settings_t, regression_t, regression_check, &
                             cross_products, sweep, path_start, path_add, regression_finish, TOL
  implicit none
  private
  public :: orthogonal_functions

contains

  !> The model of x's candidates (N, m) for y chosen by orthogonal functions
  !> and PSE, forced terms always in.  r's path is the order the functions
  !> were made in (each entering, with its partial F), to the last that
  !> could be made; the model is the path's step of least PSE.
  subroutine orthogonal_functions(x, y, forced, s, r, status, msg)
    real(wp), intent(in) :: x(:, :), y(:)
    logical, intent(in) :: forced(:)
    type(regression_settings_t), intent(in) :: s
    type(regression_t), intent(out) :: r
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: q(:, :), a(:, :)
    real(wp) :: e(size(y)), qq(size(forced)), x2(size(forced)), sse, red
    logical :: in(size(forced))
    integer :: j, m, n, ierr, kbest

    call regression_check(x, y, forced, s, .false., .false., status, msg)
    if (status /= MLID_OK) return
    m = size(forced)
    n = size(y)
    allocate (q(n, m), a(m + 1, m + 1), stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'orthogonal functions: out of memory for '//itoa(n)//' x '//itoa(m)//' values'
      return
    end if
    q = x
    e = y
    in = .false.
    do j = 1, m
      x2(j) = dot_product(x(:, j), x(:, j))
      qq(j) = x2(j)
    end do
    do j = 1, m                                   ! the forced terms first
      if (.not. forced(j)) cycle
      if (qq(j) <= TOL*x2(j)) then
        status = MLID_ERR_INPUT
        msg = 'model structure: forced term '//itoa(j)//' is (nearly) a combination of '// &
              'the forced terms before it'
        return
      end if
      call take(q, qq, e, in, j, red)
    end do
    call path_start(r, m, m, y, s, count(in), dot_product(e, e), status, msg)
    if (status /= MLID_OK) return
    do
      j = best_function(q, qq, x2, e, in)
      if (j == 0 .or. n - count(in) - 1 < 1) exit
      call take(q, qq, e, in, j, red)
      sse = dot_product(e, e)
      call path_add(r, j, red/(sse/(n - count(in))), y, count(in), sse, status, msg)
      if (status /= MLID_OK) return
    end do
    kbest = minloc(r%path_pse(0:r%nsteps), 1) - 1
    in = forced
    do j = 1, kbest
      in(r%term(j)) = .true.
    end do
    call cross_products(x, y, a, status, msg)
    if (status /= MLID_OK) return
    do j = 1, m
      if (in(j)) call sweep(a, j, .true.)
    end do
    call regression_finish(x, y, in, a, r, status, msg)
  end subroutine orthogonal_functions

  !> Candidate j's orthogonal function joins the model: the residual e and
  !> the candidates still out are orthogonalised on it; red is the
  !> reduction of the residual sum of squares.
  subroutine take(q, qq, e, in, j, red)
    real(wp), intent(inout) :: q(:, :), qq(:), e(:)
    logical, intent(inout) :: in(:)
    integer, intent(in) :: j
    real(wp), intent(out) :: red
    real(wp) :: c
    integer :: k
    in(j) = .true.
    c = dot_product(q(:, j), e)/qq(j)
    red = c*c*qq(j)
    e = e - c*q(:, j)
    do k = 1, size(in)
      if (in(k)) cycle
      c = dot_product(q(:, j), q(:, k))/qq(j)
      q(:, k) = q(:, k) - c*q(:, j)
      qq(k) = dot_product(q(:, k), q(:, k))
    end do
  end subroutine take

  !> The candidate out of the model whose orthogonal function most reduces
  !> the residual sum of squares (0: none left whose function keeps more
  !> than TOL of its candidate's squared norm).
  integer function best_function(q, qq, x2, e, in) result(best)
    real(wp), intent(in) :: q(:, :), qq(:), x2(:), e(:)
    logical, intent(in) :: in(:)
    real(wp) :: red, rbest
    integer :: k
    best = 0
    rbest = -1.0_wp
    do k = 1, size(in)
      if (in(k) .or. qq(k) <= TOL*x2(k)) cycle
      red = dot_product(q(:, k), e)**2/qq(k)
      if (red > rbest) then
        best = k
        rbest = red
      end if
    end do
  end function best_function

end module mlid_orthogonal_functions
